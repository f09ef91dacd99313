//! Leaf bones get their length from their skin, and helper nodes that link skin joints are
//! bones of the character (as game rigs exported from Minecraft-like models need).

use rigfit_core::pose::bones::BoneModel;
use rigfit_core::pose::sketch::limb_chains;
use rigfit_core::{
    Joint, JointDof, JointKind, Matrix4, Point3, Rig, Skeleton, SkinnedMesh, Trs, Vector3,
};

/// A box of vertices from `low` to `high` (eight corners and the centre of each face).
fn block(low: [f64; 3], high: [f64; 3]) -> Vec<Point3> {
    let mut points = Vec::new();
    for x in [low[0], high[0]] {
        for y in [low[1], high[1]] {
            for z in [low[2], high[2]] {
                points.push(Point3::new(x, y, z));
            }
        }
    }
    points
}

/// A blocky character: a body at the origin, a head above it and an arm hanging from a
/// shoulder helper node, the head and the arm leaves; each part's vertices weighted to it.
/// The arm's block hangs 0.6 below its joint; the body's block surrounds its joint.
fn blocky() -> Rig {
    let mut body = Joint::new("Body", None, Trs::IDENTITY);
    body.kind = JointKind::Skin;
    let head = Joint::new(
        "Head",
        Some(0),
        Trs::from_translation(Vector3::new(0.0, 0.5, 0.0)),
    );
    let mut shoulder = Joint::new(
        "Shoulder",
        Some(0),
        Trs::from_translation(Vector3::new(0.3, 0.4, 0.0)),
    );
    shoulder.kind = JointKind::Helper;
    let arm = Joint::new("Arm", Some(2), Trs::IDENTITY);
    let mut skeleton = Skeleton::new(vec![body, head, shoulder, arm]).expect("parents first");
    skeleton.set_default_dofs();
    let pose = skeleton.rest_pose();
    let world = skeleton.world_matrices(&pose);
    let parts = [
        (0u32, block([-0.2, -0.3, -0.1], [0.2, 0.4, 0.1])),
        (1, block([-0.15, 0.5, -0.15], [0.15, 0.8, 0.15])),
        (3, block([0.25, -0.2, -0.05], [0.35, 0.4, 0.05])),
    ];
    let mut positions = Vec::new();
    let mut joints = Vec::new();
    let mut weights = Vec::new();
    for (joint, points) in parts {
        for p in points {
            positions.push(p);
            joints.push([joint, 0, 0, 0]);
            weights.push([1.0, 0.0, 0.0, 0.0]);
        }
    }
    let inverse_bind: Vec<Matrix4> = world
        .iter()
        .map(|m| m.try_inverse().expect("invertible"))
        .collect();
    let mesh = SkinnedMesh {
        name: "blocks".into(),
        positions,
        normals: None,
        triangles: Vec::new(),
        joints,
        weights,
        inverse_bind,
    };
    Rig {
        skeleton,
        pose,
        meshes: vec![mesh],
        animations: Vec::new(),
    }
}

#[test]
fn leaf_joints_get_a_tip_at_the_far_end_of_their_skin() {
    let mut rig = blocky();
    assert_eq!(rig.tip_skinned_leaves(), 2, "the head and the arm");
    let skeleton = &rig.skeleton;
    assert_eq!(skeleton.len(), 6);
    assert_eq!(rig.pose.local.len(), 6);
    assert!(rig.meshes[0].inverse_bind.len() == 6);
    let positions = skeleton.joint_positions(&rig.pose);
    let head_end = skeleton.find("Head_end").expect("a head tip");
    let arm_end = skeleton.find("Arm_end").expect("an arm tip");
    for end in [head_end, arm_end] {
        assert_eq!(skeleton.joint(end).kind, JointKind::SkinTip);
        assert_eq!(skeleton.joint(end).dof, JointDof::Fixed);
    }
    // The head's block reaches 0.3 above its joint, straight up.
    assert!((positions[head_end] - Point3::new(0.0, 0.8, 0.0)).norm() < 0.02);
    // The arm's block hangs below the shoulder at (0.3, 0.4): its tip is near the bottom.
    let arm = positions[arm_end];
    assert!(arm.y < -0.1 && (arm.x - 0.3).abs() < 0.05, "{arm:?}");
    // The body is not a leaf; its skin surrounds it anyway.
    assert!(skeleton.find("Body_end").is_none());
    // Tips are not in the file: never reported.
    assert_eq!(rig.reported_joints().count(), 3, "body, head and arm");
    // Calling it again adds nothing: the tips carry no skin.
    assert_eq!(rig.tip_skinned_leaves(), 0);
}

#[test]
fn helper_nodes_between_skin_joints_are_bones() {
    let mut rig = blocky();
    rig.tip_skinned_leaves();
    let skeleton = &rig.skeleton;
    let linking = skeleton.linking_helpers();
    let shoulder = skeleton.find("Shoulder").expect("Shoulder");
    assert!(linking[shoulder]);
    assert_eq!(linking.iter().filter(|&&l| l).count(), 1);
    // The arm's chain runs through the shoulder node to the arm's tip.
    let chains = limb_chains(skeleton);
    let arm_end = skeleton.find("Arm_end").expect("Arm_end");
    let arm_chain = chains
        .iter()
        .find(|c| c.last() == Some(&arm_end))
        .expect("a chain to the arm's tip");
    assert!(arm_chain.contains(&shoulder));
    // The posing model has the bone from the body to the shoulder node.
    let model = BoneModel::new(skeleton, &rig.pose, 0.05, 1e-6);
    assert!(model.bones.iter().any(|b| b.child == shoulder));
}

#[test]
fn helper_leaves_and_helpers_above_the_root_are_not_bones() {
    let mut top = Joint::new("Armature", None, Trs::IDENTITY);
    top.kind = JointKind::Helper;
    let hips = Joint::new("Hips", Some(0), Trs::IDENTITY);
    let leg = Joint::new(
        "Leg",
        Some(1),
        Trs::from_translation(Vector3::new(0.0, -1.0, 0.0)),
    );
    let mut socket = Joint::new(
        "Socket",
        Some(1),
        Trs::from_translation(Vector3::new(0.5, 0.0, 0.0)),
    );
    socket.kind = JointKind::Helper;
    let skeleton = Skeleton::new(vec![top, hips, leg, socket]).expect("parents first");
    assert_eq!(skeleton.linking_helpers(), vec![false; 4]);
    let model = BoneModel::new(&skeleton, &skeleton.rest_pose(), 0.05, 1e-6);
    assert!(model.bones.iter().all(|b| b.child != 3));
}
