//! The default degrees of freedom of a character read from a file, in time linear in its
//! joints (the same rule as `Skeleton::set_default_dofs`, which walks up the tree per joint:
//! quadratic in a deep chain).

use rigfit_core::{JointDof, JointKind, Skeleton};

/// The deepest joint that is an ancestor (or self) of every skin joint (`None` when skin
/// joints live in separate trees or there are none): the first joint, going up from the
/// first skin joint, whose subtree holds every skin joint.
pub(crate) fn skin_root(skeleton: &Skeleton) -> Option<usize> {
    let n = skeleton.len();
    // Parents come before children: a reverse sweep sums each subtree's skin joints.
    let mut below = vec![0usize; n];
    for i in (0..n).rev() {
        if skeleton.joint(i).kind == JointKind::Skin {
            below[i] += 1;
        }
        if let Some(p) = skeleton.joint(i).parent {
            below[p] += below[i];
        }
    }
    let total = (0..n)
        .filter(|&i| skeleton.joint(i).kind == JointKind::Skin)
        .count();
    let first = (0..n).find(|&i| skeleton.joint(i).kind == JointKind::Skin)?;
    let mut candidate = Some(first);
    while let Some(c) = candidate {
        if below[c] == total {
            return Some(c);
        }
        candidate = skeleton.joint(c).parent;
    }
    None
}

/// Sets the default degrees of freedom: the skin root (or every root when the skin is a
/// forest) is free, other skin joints are ball joints, helpers above the root and end sites
/// are fixed; limits are kept.
pub(crate) fn set_default_dofs(skeleton: &mut Skeleton) {
    let root = skin_root(skeleton);
    let n = skeleton.len();
    let mut under_root = vec![root.is_none(); n];
    for i in 0..n {
        if root.is_some() {
            under_root[i] =
                Some(i) == root || skeleton.joint(i).parent.is_some_and(|p| under_root[p]);
        }
        let j = skeleton.joint(i);
        let dof = if Some(i) == root || (root.is_none() && j.parent.is_none()) {
            JointDof::Free
        } else if j.kind == JointKind::EndSite || !under_root[i] {
            JointDof::Fixed
        } else {
            JointDof::Ball
        };
        let limits = j.limits;
        skeleton.set_dof(i, dof, limits);
    }
}

#[cfg(test)]
mod tests {
    use rigfit_core::{Joint, Trs};

    use super::*;

    #[test]
    fn same_as_the_core_rule() {
        // A helper above the skin, a skin chain with a branch, an end site.
        let mut joints = vec![Joint::new("helper", None, Trs::default())];
        joints[0].kind = JointKind::Helper;
        for (name, parent) in [("hips", 0), ("spine", 1), ("leg", 1), ("head", 2)] {
            joints.push(Joint::new(name, Some(parent), Trs::default()));
        }
        let mut end = Joint::new("end", Some(4), Trs::default());
        end.kind = JointKind::EndSite;
        joints.push(end);
        let mut other = Joint::new("prop", None, Trs::default());
        other.kind = JointKind::Helper;
        joints.push(other);
        let skeleton = Skeleton::new(joints).expect("tree");
        let mut ours = skeleton.clone();
        set_default_dofs(&mut ours);
        let mut core = skeleton;
        core.set_default_dofs();
        assert_eq!(ours, core);
        assert_eq!(skin_root(&ours), core.skin_root());
    }
}
