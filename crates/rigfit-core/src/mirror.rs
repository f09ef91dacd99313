//! Left and right: the joints of a skeleton paired with their mirror images by name.

use crate::skeleton::Skeleton;

/// Left-right pairs of joints by name (`Left`/`Right`, `L`/`R` or `l`/`r` as a word or
/// before a capital, as in `LHipJoint`, `B_Hip_L`, `Arm.L`, `lShldr`, and a final `L`
/// after a lower-case letter, as in `ArmL`): `(left, right)` for each left joint whose
/// right name exists.
pub fn mirror_pairs(skeleton: &Skeleton) -> Vec<(usize, usize)> {
    (0..skeleton.len())
        .filter_map(|left| {
            right_names(&skeleton.joint(left).name)
                .iter()
                .find_map(|name| skeleton.find(name))
                .filter(|&right| right != left)
                .map(|right| (left, right))
        })
        .collect()
}

/// The names a right-side counterpart of `name` may have.
fn right_names(name: &str) -> Vec<String> {
    let mut names = Vec::new();
    for (left, right) in [("Left", "Right"), ("left", "right"), ("LEFT", "RIGHT")] {
        for (at, _) in name.match_indices(left) {
            names.push(format!(
                "{}{right}{}",
                &name[..at],
                &name[at + left.len()..]
            ));
        }
    }
    let bytes = name.as_bytes();
    let separator = |b: u8| matches!(b, b'_' | b'.' | b'-' | b':' | b' ' | b'|');
    for (at, &b) in bytes.iter().enumerate() {
        if b != b'L' && b != b'l' {
            continue;
        }
        let word_start = at == 0 || separator(bytes[at - 1]);
        let word_end = bytes
            .get(at + 1)
            .is_none_or(|&next| separator(next) || next.is_ascii_uppercase());
        let final_capital =
            b == b'L' && at + 1 == bytes.len() && at > 0 && bytes[at - 1].is_ascii_lowercase();
        if (word_start && word_end) || final_capital {
            let right = if b == b'L' { "R" } else { "r" };
            names.push(format!("{}{right}{}", &name[..at], &name[at + 1..]));
        }
    }
    names
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn mirror_names_follow_the_usual_conventions() {
        for (left, right) in [
            ("LeftArm", "RightArm"),
            ("mixamorig:LeftHand", "mixamorig:RightHand"),
            ("LHipJoint", "RHipJoint"),
            ("B_Hip_Left", "B_Hip_Right"),
            ("HindLeg_L_01", "HindLeg_R_01"),
            ("Ear_L", "Ear_R"),
            ("upper_arm.L", "upper_arm.R"),
            ("thigh_l", "thigh_r"),
            ("lShldr", "rShldr"),
            ("Bip01 L Thigh", "Bip01 R Thigh"),
            ("ArmL", "ArmR"),
        ] {
            assert!(
                right_names(left).iter().any(|n| n == right),
                "{left} -> {right}: {:?}",
                right_names(left)
            );
        }
        for centre in ["Leg", "LowerBack", "Neck1", "B_Root_Pelvis_T", "Lip"] {
            assert!(right_names(centre).is_empty(), "{centre}");
        }
    }
}
