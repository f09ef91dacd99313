//! A procedural humanoid: a 26-joint skeleton (21 deforming joints plus five tip joints)
//! with a simple skinned body of capsule-like tubes, about 1.75 units tall, y up, facing +z.
//! It lets every command run with nothing downloaded.

use crate::animation::{Animation, AnimationChannel, ChannelTarget, Interpolation, quat_to_xyzw};
use crate::math::{Matrix4, Point3, Quat, Trs, Vector3};
use crate::rig::Rig;
use crate::skeleton::{Joint, Skeleton};
use crate::skinning::SkinnedMesh;

/// (name, parent name, offset from the parent, tube radius of the bone from this joint to
/// its first child).
const JOINTS: &[(&str, &str, [f64; 3], f64)] = &[
    ("Hips", "", [0.0, 0.95, 0.0], 0.13),
    ("Spine", "Hips", [0.0, 0.1, 0.0], 0.13),
    ("Chest", "Spine", [0.0, 0.18, 0.0], 0.15),
    ("Neck", "Chest", [0.0, 0.22, 0.0], 0.05),
    ("Head", "Neck", [0.0, 0.1, 0.0], 0.1),
    ("HeadTop", "Head", [0.0, 0.2, 0.0], 0.0),
    ("LeftShoulder", "Chest", [0.04, 0.18, 0.0], 0.05),
    ("LeftArm", "LeftShoulder", [0.14, 0.0, 0.0], 0.05),
    ("LeftForeArm", "LeftArm", [0.28, 0.0, 0.0], 0.04),
    ("LeftHand", "LeftForeArm", [0.25, 0.0, 0.0], 0.035),
    ("LeftHandTip", "LeftHand", [0.17, 0.0, 0.0], 0.0),
    ("RightShoulder", "Chest", [-0.04, 0.18, 0.0], 0.05),
    ("RightArm", "RightShoulder", [-0.14, 0.0, 0.0], 0.05),
    ("RightForeArm", "RightArm", [-0.28, 0.0, 0.0], 0.04),
    ("RightHand", "RightForeArm", [-0.25, 0.0, 0.0], 0.035),
    ("RightHandTip", "RightHand", [-0.17, 0.0, 0.0], 0.0),
    ("LeftUpLeg", "Hips", [0.09, -0.03, 0.0], 0.07),
    ("LeftLeg", "LeftUpLeg", [0.0, -0.42, 0.0], 0.055),
    ("LeftFoot", "LeftLeg", [0.0, -0.42, 0.0], 0.04),
    ("LeftToeBase", "LeftFoot", [0.0, -0.06, 0.12], 0.035),
    ("LeftToeTip", "LeftToeBase", [0.0, 0.0, 0.07], 0.0),
    ("RightUpLeg", "Hips", [-0.09, -0.03, 0.0], 0.07),
    ("RightLeg", "RightUpLeg", [0.0, -0.42, 0.0], 0.055),
    ("RightFoot", "RightLeg", [0.0, -0.42, 0.0], 0.04),
    ("RightToeBase", "RightFoot", [0.0, -0.06, 0.12], 0.035),
    ("RightToeTip", "RightToeBase", [0.0, 0.0, 0.07], 0.0),
];

/// Sides of each tube's cross-section.
const TUBE_SIDES: usize = 10;
/// Rings along each tube (including both ends).
const TUBE_RINGS: usize = 6;

/// The built-in humanoid: skeleton with default degrees of freedom, rest pose as its stored
/// pose, one skinned body mesh and a two-second "wave" animation.
pub fn humanoid() -> Rig {
    let names: Vec<&str> = JOINTS.iter().map(|j| j.0).collect();
    let joints: Vec<Joint> = JOINTS
        .iter()
        .map(|&(name, parent, offset, _)| {
            let parent = names.iter().position(|n| *n == parent);
            Joint::new(name, parent, Trs::from_translation(Vector3::from(offset)))
        })
        .collect();
    let mut skeleton = Skeleton::new(joints).expect("the built-in joint table is parents-first");
    skeleton.set_default_dofs();
    let pose = skeleton.rest_pose();
    let world = skeleton.world_matrices(&pose);
    let mesh = body_mesh(&skeleton, &world);
    let animations = vec![wave(&skeleton)];
    Rig {
        skeleton,
        pose,
        meshes: vec![mesh],
        animations,
    }
}

fn body_mesh(skeleton: &Skeleton, world: &[Matrix4]) -> SkinnedMesh {
    let pos = |j: usize| Point3::new(world[j][(0, 3)], world[j][(1, 3)], world[j][(2, 3)]);
    let mut mesh = SkinnedMesh {
        name: "Body".into(),
        inverse_bind: world
            .iter()
            .map(|m| m.try_inverse().unwrap_or_else(Matrix4::identity))
            .collect(),
        normals: Some(Vec::new()),
        ..Default::default()
    };
    for (j, &(_, _, _, radius)) in JOINTS.iter().enumerate() {
        if radius <= 0.0 {
            continue;
        }
        let Some(&child) = skeleton.children(j).first() else {
            continue;
        };
        let parent = skeleton.joint(j).parent;
        add_tube(&mut mesh, pos(j), pos(child), radius, j, parent, child);
    }
    mesh
}

/// Appends a capped tube from `a` to `b`, carried by `joint`; its first ring blends with
/// `parent` and its last with `child`.
fn add_tube(
    mesh: &mut SkinnedMesh,
    a: Point3,
    b: Point3,
    radius: f64,
    joint: usize,
    parent: Option<usize>,
    child: usize,
) {
    let axis = (b - a).normalize();
    let (u, v) = crate::math::perpendicular_basis(&axis);
    let base = mesh.positions.len() as u32;
    let normals = mesh.normals.get_or_insert_with(Vec::new);
    let j = joint as u32;
    for ring in 0..TUBE_RINGS {
        let t = ring as f64 / (TUBE_RINGS - 1) as f64;
        let centre = a + (b - a) * t;
        let (influence, weights) = if ring == 0 {
            match parent {
                Some(p) => ([j, p as u32, 0, 0], [0.5, 0.5, 0.0, 0.0]),
                None => ([j, 0, 0, 0], [1.0, 0.0, 0.0, 0.0]),
            }
        } else if ring == TUBE_RINGS - 1 {
            ([j, child as u32, 0, 0], [0.5, 0.5, 0.0, 0.0])
        } else {
            ([j, 0, 0, 0], [1.0, 0.0, 0.0, 0.0])
        };
        // Taper the ends a little so neighbouring tubes blend into a body.
        let r = radius * (1.0 - 0.15 * (2.0 * t - 1.0).powi(2));
        for side in 0..TUBE_SIDES {
            let angle = side as f64 / TUBE_SIDES as f64 * std::f64::consts::TAU;
            let dir = u * angle.cos() + v * angle.sin();
            mesh.positions.push(centre + dir * r);
            normals.push(dir);
            mesh.joints.push(influence);
            mesh.weights.push(weights);
        }
    }
    let sides = TUBE_SIDES as u32;
    for ring in 0..(TUBE_RINGS as u32 - 1) {
        for side in 0..sides {
            let i0 = base + ring * sides + side;
            let i1 = base + ring * sides + (side + 1) % sides;
            let i2 = i0 + sides;
            let i3 = i1 + sides;
            mesh.triangles.push([i0, i1, i3]);
            mesh.triangles.push([i0, i3, i2]);
        }
    }
    // Caps: a centre vertex at each end.
    for (end, centre, ring, n) in [(0u32, a, 0u32, -axis), (1, b, TUBE_RINGS as u32 - 1, axis)] {
        let c = mesh.positions.len() as u32;
        let first = (base + ring * sides) as usize;
        let (influence, weights) = (mesh.joints[first], mesh.weights[first]);
        mesh.positions.push(centre);
        mesh.normals.get_or_insert_with(Vec::new).push(n);
        mesh.joints.push(influence);
        mesh.weights.push(weights);
        for side in 0..sides {
            let i0 = base + ring * sides + side;
            let i1 = base + ring * sides + (side + 1) % sides;
            mesh.triangles
                .push(if end == 0 { [c, i1, i0] } else { [c, i0, i1] });
        }
    }
}

/// A two-second wave: the right arm lifts and the forearm swings, the head turns.
fn wave(skeleton: &Skeleton) -> Animation {
    let times = vec![0.0, 0.5, 1.0, 1.5, 2.0];
    let key = |joint: &str, angles: [[f64; 3]; 5]| {
        let joint = skeleton.find(joint).expect("built-in joint");
        AnimationChannel {
            joint,
            target: ChannelTarget::Rotation,
            interpolation: Interpolation::Linear,
            times: times.clone(),
            values: angles
                .iter()
                .map(|a| quat_to_xyzw(&Quat::from_euler_angles(a[0], a[1], a[2])))
                .collect(),
        }
    };
    Animation {
        name: "wave".into(),
        channels: vec![
            key(
                "RightArm",
                [
                    [0.0; 3],
                    [0.0, 0.0, -1.2],
                    [0.0, 0.0, -1.4],
                    [0.0, 0.0, -1.2],
                    [0.0; 3],
                ],
            ),
            key(
                "RightForeArm",
                [
                    [0.0; 3],
                    [0.0, 0.6, -0.3],
                    [0.0, -0.6, -0.3],
                    [0.0, 0.6, -0.3],
                    [0.0; 3],
                ],
            ),
            key(
                "Head",
                [
                    [0.0; 3],
                    [0.0, 0.4, 0.0],
                    [0.0, -0.4, 0.0],
                    [0.0, 0.4, 0.0],
                    [0.0; 3],
                ],
            ),
            key(
                "LeftUpLeg",
                [
                    [0.0; 3],
                    [-0.3, 0.0, 0.0],
                    [0.0; 3],
                    [-0.3, 0.0, 0.0],
                    [0.0; 3],
                ],
            ),
        ],
        frame_time: None,
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn humanoid_is_a_standing_character() {
        let rig = humanoid();
        assert_eq!(rig.skeleton.len(), 26);
        let h = rig.height();
        assert!((1.6..1.9).contains(&h), "height {h}");
        let mesh = &rig.meshes[0];
        assert_eq!(mesh.positions.len(), mesh.joints.len());
        assert!(
            mesh.triangles
                .iter()
                .flatten()
                .all(|&i| (i as usize) < mesh.positions.len())
        );
        // At the bind pose, skinning is the identity.
        let world = rig.skeleton.world_matrices(&rig.pose);
        let (skinned, _) = mesh.skin(&world);
        for (a, b) in skinned.iter().zip(&mesh.positions) {
            assert!((a - b).norm() < 1e-12);
        }
    }
}
