//! Tests of the BVH reader and writer: the real CMU file, round trips, the pose and
//! animation semantics, Euler conversions for every channel order, and malformed files.

use std::path::{Path, PathBuf};
use std::sync::OnceLock;

use rigfit_core::kinematics::numeric_point_jacobian;
use rigfit_core::{
    DofLayout, ForwardKinematics, Joint, JointDof, JointKind, Point3, Quat, Skeleton, Trs, Vector3,
};
use rigfit_formats::bvh::{BvhChannel, BvhDocument, BvhJoint, parse_bvh, read_bvh};

fn cmu_path() -> PathBuf {
    rigfit_testkit::assets::asset("cmu/01_01.bvh")
}

/// The CMU file's text and parsed document, read once.
fn cmu() -> &'static (String, BvhDocument) {
    static CMU: OnceLock<(String, BvhDocument)> = OnceLock::new();
    CMU.get_or_init(|| {
        let path = cmu_path();
        let text = std::fs::read_to_string(&path).expect("the CMU test file is readable");
        let doc = read_bvh(&path).expect("01_01.bvh parses");
        (text, doc)
    })
}

/// Deterministic pseudo-random numbers in [-1, 1).
fn rand(state: &mut u64) -> f64 {
    *state = state
        .wrapping_mul(6364136223846793005)
        .wrapping_add(1442695040888963407);
    ((*state >> 11) as f64 / (1u64 << 53) as f64) * 2.0 - 1.0
}

fn positions(doc: &BvhDocument, frame: usize) -> Vec<Point3> {
    doc.skeleton().joint_positions(&doc.pose_at_frame(frame))
}

fn max_distance(a: &[Point3], b: &[Point3]) -> f64 {
    assert_eq!(a.len(), b.len());
    a.iter()
        .zip(b)
        .map(|(p, q)| (p - q).norm())
        .fold(0.0, f64::max)
}

#[test]
fn cmu_counts_match_the_file() {
    let (text, doc) = cmu();
    let first_word = |l: &str| l.split_whitespace().next().unwrap_or("").to_string();
    let joint_keywords = text
        .lines()
        .filter(|l| matches!(first_word(l).as_str(), "ROOT" | "JOINT"))
        .count();
    let end_sites = text.lines().filter(|l| l.trim() == "End Site").count();
    let header: usize = text
        .lines()
        .find_map(|l| l.trim().strip_prefix("Frames:"))
        .expect("a Frames: line")
        .trim()
        .parse()
        .expect("a frame count");
    let rows = text
        .lines()
        .skip_while(|l| !l.trim_start().starts_with("Frame Time:"))
        .skip(1)
        .filter(|l| !l.trim().is_empty())
        .count();

    assert_eq!(joint_keywords, 31);
    assert_eq!(
        doc.joints.iter().filter(|j| !j.end_site).count(),
        joint_keywords
    );
    assert_eq!(doc.joints.iter().filter(|j| j.end_site).count(), end_sites);
    assert_eq!(doc.frames.len(), rows);
    // This copy holds exactly the rows its header announces.
    assert_eq!(header, 2752);
    assert_eq!(rows, header);
    assert!((doc.frame_time - 0.0083333).abs() < 1e-15);
    assert_eq!(doc.channel_count(), 6 + 30 * 3);
    assert!(doc.frames.iter().all(|f| f.len() == doc.channel_count()));

    let hips = &doc.joints[0];
    assert_eq!(hips.name, "Hips");
    assert_eq!(hips.parent, None);
    assert_eq!(
        hips.channels,
        [
            BvhChannel::Xposition,
            BvhChannel::Yposition,
            BvhChannel::Zposition,
            BvhChannel::Zrotation,
            BvhChannel::Yrotation,
            BvhChannel::Xrotation
        ]
    );
    // End Sites are named after their parent.
    let toe_end = doc
        .find("LeftToeBase_End")
        .expect("the left toe's End Site");
    assert!(doc.joints[toe_end].end_site);
    assert_eq!(doc.joints[toe_end].offset, Vector3::new(0.0, -0.0, 1.18966));
    assert_eq!(doc.joints[toe_end].parent, doc.find("LeftToeBase"));
    // Parents first.
    for (i, j) in doc.joints.iter().enumerate() {
        assert!(j.parent.is_none_or(|p| p < i));
    }
    let skeleton = doc.skeleton();
    assert_eq!(skeleton.len(), doc.joints.len());
    assert_eq!(skeleton.joint(toe_end).kind, JointKind::EndSite);
    assert_eq!(skeleton.joint(0).dof, JointDof::Free);
    assert_eq!(skeleton.joint(toe_end).dof, JointDof::Fixed);
}

#[test]
fn cmu_write_read_round_trip_is_exact() {
    let (_, doc) = cmu();
    let text = doc.to_bvh_string();
    let back = parse_bvh(text.as_bytes()).expect("written BVH parses");
    assert_eq!(
        &back, doc,
        "hierarchy, frame time and every value survive exactly"
    );
    assert_eq!(back.to_bvh_string(), text);

    let dir = tempfile::tempdir().expect("a temporary directory");
    let path = dir.path().join("out.bvh");
    doc.write(&path).expect("write");
    let from_file = read_bvh(&path).expect("read back");
    assert_eq!(&from_file, doc);
    let leftovers: Vec<_> = std::fs::read_dir(dir.path())
        .expect("list")
        .filter_map(|e| e.ok())
        .filter(|e| e.file_name() != "out.bvh")
        .collect();
    assert!(leftovers.is_empty(), "no temporary file is left behind");
}

/// Elementary rotation matrix, written out by hand.
fn rot(axis: char, degrees: f64) -> [[f64; 3]; 3] {
    let (s, c) = degrees.to_radians().sin_cos();
    match axis {
        'X' => [[1.0, 0.0, 0.0], [0.0, c, -s], [0.0, s, c]],
        'Y' => [[c, 0.0, s], [0.0, 1.0, 0.0], [-s, 0.0, c]],
        'Z' => [[c, -s, 0.0], [s, c, 0.0], [0.0, 0.0, 1.0]],
        _ => panic!("axis {axis}"),
    }
}

fn mat_mul(a: &[[f64; 3]; 3], b: &[[f64; 3]; 3]) -> [[f64; 3]; 3] {
    let mut m = [[0.0; 3]; 3];
    for i in 0..3 {
        for j in 0..3 {
            m[i][j] = (0..3).map(|k| a[i][k] * b[k][j]).sum();
        }
    }
    m
}

fn mat_vec(a: &[[f64; 3]; 3], v: [f64; 3]) -> [f64; 3] {
    std::array::from_fn(|i| (0..3).map(|k| a[i][k] * v[k]).sum())
}

/// The first chain of the CMU file (Hips down to the left toe's End Site), computed from
/// the raw text without the library: world position = parent position + parent rotation *
/// (offset + position channels); rotation = parent rotation * product of the rotation
/// channels in file order.
#[test]
fn cmu_pose_matches_an_independent_reference() {
    let (text, doc) = cmu();
    let mut offsets: Vec<[f64; 3]> = Vec::new();
    let mut channels: Vec<Vec<String>> = Vec::new();
    let mut names: Vec<String> = Vec::new();
    for line in text.lines() {
        let words: Vec<&str> = line.split_whitespace().collect();
        match words.first().copied() {
            Some("ROOT") | Some("JOINT") => names.push(words[1].to_string()),
            Some("End") => names.push("End Site".into()),
            Some("OFFSET") => offsets.push(std::array::from_fn(|k| {
                words[k + 1].parse().expect("offset number")
            })),
            Some("CHANNELS") => channels.push(words[2..].iter().map(|w| w.to_string()).collect()),
            Some("}") => break,
            _ => {}
        }
    }
    channels.push(Vec::new()); // the End Site
    assert_eq!(names.len(), 7);
    let rows: Vec<&str> = text
        .lines()
        .skip_while(|l| !l.starts_with("Frame Time:"))
        .skip(1)
        .collect();
    let skeleton = doc.skeleton();
    for frame in [0, 1, 100, 1234, 2751] {
        let values: Vec<f64> = rows[frame]
            .split_whitespace()
            .map(|v| v.parse().expect("value"))
            .collect();
        let mut position = [0.0; 3];
        let mut rotation = [[1.0, 0.0, 0.0], [0.0, 1.0, 0.0], [0.0, 0.0, 1.0]];
        let mut next = 0;
        let library = skeleton.joint_positions(&doc.pose_at_frame(frame));
        for j in 0..names.len() {
            let mut local_t = offsets[j];
            let mut local_r = [[1.0, 0.0, 0.0], [0.0, 1.0, 0.0], [0.0, 0.0, 1.0]];
            for ch in &channels[j] {
                let v = values[next];
                next += 1;
                let axis = ch.chars().next().expect("axis letter");
                if ch.ends_with("position") {
                    local_t[(axis as u8 - b'X') as usize] += v;
                } else {
                    local_r = mat_mul(&local_r, &rot(axis, v));
                }
            }
            let moved = mat_vec(&rotation, local_t);
            position = std::array::from_fn(|k| position[k] + moved[k]);
            rotation = mat_mul(&rotation, &local_r);
            assert_eq!(doc.joints[j].end_site, names[j] == "End Site");
            let p = library[j];
            let err = (0..3)
                .map(|k| (p[k] - position[k]).abs())
                .fold(0.0, f64::max);
            assert!(
                err < 1e-9,
                "frame {frame}, {}: {p} vs {position:?}",
                names[j]
            );
        }
    }
}

#[test]
fn cmu_set_frame_from_pose_reproduces_positions() {
    let (_, doc) = cmu();
    let mut copy = doc.clone();
    for frame in [0, 1, 100, 777, 2000, 2751] {
        let pose = doc.pose_at_frame(frame);
        let reference = positions(doc, frame);
        // Overwrite the frame itself, and append it as a new frame.
        copy.frames[frame] = vec![0.0; doc.channel_count()];
        copy.set_frame_from_pose(frame, &pose);
        assert!(max_distance(&positions(&copy, frame), &reference) < 1e-9);
        let end = copy.frames.len();
        copy.set_frame_from_pose(end, &pose);
        assert_eq!(copy.frames.len(), end + 1);
        assert!(max_distance(&positions(&copy, end), &reference) < 1e-9);
        for (a, b) in copy.pose_at_frame(end).local.iter().zip(&pose.local) {
            assert!(a.rotation.angle_to(&b.rotation) < 1e-9);
            assert!((a.translation - b.translation).norm() < 1e-9);
        }
    }
}

/// A small document with one joint per rotation order and some channel subsets.
fn order_document(order: [usize; 3]) -> BvhDocument {
    let rotation = |a: usize| BvhChannel::rotation(a);
    let full: Vec<BvhChannel> = order.iter().map(|&a| rotation(a)).collect();
    let joint =
        |name: &str, parent: Option<usize>, offset: [f64; 3], channels: Vec<BvhChannel>| BvhJoint {
            name: name.into(),
            parent,
            offset: Vector3::from(offset),
            channels,
            end_site: false,
        };
    let mut root_channels = vec![
        BvhChannel::Zposition,
        BvhChannel::Xposition,
        BvhChannel::Yposition,
    ];
    root_channels.extend(full.iter().copied());
    let mut with_position = vec![BvhChannel::Yposition];
    with_position.extend(full.iter().copied());
    with_position.push(BvhChannel::Xposition);
    let mut joints = vec![
        joint("root", None, [1.0, 2.0, 3.0], root_channels),
        joint("a", Some(0), [0.0, 4.0, 0.5], full.clone()),
        joint("b", Some(1), [1.5, 0.0, -2.0], with_position),
        joint(
            "two",
            Some(2),
            [0.0, 3.0, 0.0],
            vec![rotation(order[2]), rotation(order[0])],
        ),
        joint("one", Some(3), [0.0, 0.0, 2.0], vec![rotation(order[1])]),
        joint("b2", Some(1), [-1.0, 1.0, 1.0], full),
    ];
    joints.push(BvhJoint {
        name: "one_End".into(),
        parent: Some(4),
        offset: Vector3::new(0.5, 0.5, 0.5),
        channels: Vec::new(),
        end_site: true,
    });
    BvhDocument {
        joints,
        frame_time: 1.0 / 30.0,
        frames: Vec::new(),
    }
}

#[test]
fn set_frame_from_pose_handles_every_rotation_order() {
    let orders = [
        [0, 1, 2],
        [0, 2, 1],
        [1, 0, 2],
        [1, 2, 0],
        [2, 0, 1],
        [2, 1, 0],
    ];
    let mut seed = 11u64;
    for order in orders {
        let mut doc = order_document(order);
        let count = doc.channel_count();
        for f in 0..25 {
            let mut row: Vec<f64> = (0..count).map(|_| rand(&mut seed) * 180.0).collect();
            if f == 0 {
                // Middle angle at exactly +-90 degrees: gimbal lock.
                row[4] = 90.0;
                row[7] = -90.0;
            }
            doc.frames.push(row);
        }
        // Through the file format too: the parser must read any order and subset.
        let doc = parse_bvh(doc.to_bvh_string().as_bytes()).expect("parses");
        let mut rebuilt = BvhDocument {
            frames: Vec::new(),
            ..doc.clone()
        };
        for f in 0..doc.frames.len() {
            rebuilt.set_frame_from_pose(f, &doc.pose_at_frame(f));
            let err = max_distance(&positions(&rebuilt, f), &positions(&doc, f));
            assert!(err < 1e-9, "order {order:?}, frame {f}: {err}");
            for (j, (a, b)) in rebuilt
                .pose_at_frame(f)
                .local
                .iter()
                .zip(&doc.pose_at_frame(f).local)
                .enumerate()
            {
                assert!(
                    a.rotation.angle_to(&b.rotation) < 1e-9,
                    "order {order:?} joint {j}"
                );
            }
        }
        assert_eq!(rebuilt.frames.len(), doc.frames.len());
    }
}

#[test]
fn names_with_colons_and_spaces_crlf_and_split_tokens() {
    let text = "HIERARCHY\r\n\
        ROOT mixamorig:Hips\r\n\
        {\r\n  OFFSET\r\n 0.5\r\n 1 2\r\n  CHANNELS 6\r\n Xposition Yposition\r\n Zposition Yrotation Xrotation Zrotation\r\n\
        \tJOINT mixamorig:Left Arm\r\n\t{ OFFSET 1 0 0 CHANNELS 3 Zrotation Xrotation Yrotation\r\n\
        \t\tJOINT mixamorig:Left Fore Arm {\r\n\t\t\tOFFSET 2 0 0\r\n\t\t\tCHANNELS 1 Zrotation\r\n\
        \t\t\tEnd Site\r\n\t\t\t{\r\n\t\t\t\tOFFSET 1.5 0 0\r\n\t\t\t}\r\n\t\t}\r\n\t}\r\n}\r\n\
        ROOT Prop: Sword 2\r\n{\r\nOFFSET 5 5 5\r\nCHANNELS 3 Xposition Yposition Zposition\r\n}\r\n\
        MOTION\r\nFrames: 2\r\nFrame Time: .0083333\r\n\
        0 0 0 0 0 0 0 0 0 0 1 2 3\r\n\
        1 2 3 10 20 30 40 50 60 70 -1 -2 -3\r\n";
    let doc = parse_bvh(text.as_bytes()).expect("parses");
    let names: Vec<&str> = doc.joints.iter().map(|j| j.name.as_str()).collect();
    assert_eq!(
        names,
        [
            "mixamorig:Hips",
            "mixamorig:Left Arm",
            "mixamorig:Left Fore Arm",
            "mixamorig:Left Fore Arm_End",
            "Prop: Sword 2"
        ]
    );
    assert_eq!(doc.joints[0].offset, Vector3::new(0.5, 1.0, 2.0));
    assert_eq!(doc.joints[4].parent, None);
    assert_eq!(doc.frame_time, 0.0083333);
    assert_eq!(doc.frames.len(), 2);
    assert_eq!(doc.frames[1][12], -3.0);
    let skeleton = doc.skeleton();
    assert_eq!(skeleton.find("mixamorig:Left Arm"), Some(1));
    // Two roots: both are free.
    assert_eq!(skeleton.joint(4).dof, JointDof::Free);
    let p = positions(&doc, 0);
    assert!((p[3] - Point3::new(5.0, 1.0, 2.0)).norm() < 1e-12);
    assert!((p[4] - Point3::new(6.0, 7.0, 8.0)).norm() < 1e-12);
    let back = parse_bvh(doc.to_bvh_string().as_bytes()).expect("round trip");
    assert_eq!(back, doc);
}

const SMALL: &str = "HIERARCHY
ROOT Hips
{
	OFFSET 0 0 0
	CHANNELS 6 Xposition Yposition Zposition Zrotation Xrotation Yrotation
	JOINT Spine
	{
		OFFSET 0 5 0
		CHANNELS 3 Zrotation Xrotation Yrotation
		End Site
		{
			OFFSET 0 5 0
		}
	}
}
MOTION
";

#[test]
fn frames_header_may_disagree_with_the_rows() {
    let rows = "0 10 0 0 0 0 0 0 0\n1 10 0 0 0 0 0 0 0\n2 10 0 0 0 0 0 0 0\n";
    // One row more than announced.
    let extra = format!("{SMALL}Frames: 2\nFrame Time: 0.04\n{rows}");
    let doc = parse_bvh(extra.as_bytes()).expect("extra row is read");
    assert_eq!(doc.frames.len(), 3);
    assert_eq!(doc.frames[2][0], 2.0);
    // One row fewer.
    let missing = format!("{SMALL}Frames: 4\nFrame Time: 0.04\n{rows}\n\n");
    let doc = parse_bvh(missing.as_bytes()).expect("missing row is tolerated");
    assert_eq!(doc.frames.len(), 3);
    // No motion at all is valid.
    let none = format!("{SMALL}Frames: 0\nFrame Time: 0.04\n");
    let doc = parse_bvh(none.as_bytes()).expect("zero frames");
    assert!(doc.frames.is_empty());
    let rig = doc.to_rig(Some(0));
    assert!(rig.animations.is_empty());
    assert_eq!(rig.pose, doc.rest_pose());
    // No trailing newline, and the file ends right after the frame time.
    let bare = format!("{SMALL}Frames: 1\nFrame Time: 0.04\n0 10 0 0 0 0 0 0 7");
    assert_eq!(
        parse_bvh(bare.as_bytes()).expect("parses").frames[0][8],
        7.0
    );
    let bare = format!("{SMALL}Frames: 0\nFrame Time: 0.04");
    assert!(
        parse_bvh(bare.as_bytes())
            .expect("parses")
            .frames
            .is_empty()
    );
}

#[test]
fn to_rig_animation_reproduces_each_frame() {
    let (_, doc) = cmu();
    let rest = doc.to_rig(None);
    assert_eq!(rest.pose, doc.rest_pose());
    for k in [0, 1, 99, 100, 1500, doc.frames.len() - 1] {
        let rig = doc.to_rig(Some(k));
        let expected = doc.pose_at_frame(k);
        assert_eq!(rig.pose, expected);
        assert_eq!(rig.animations.len(), 1);
        let anim = &rig.animations[0];
        assert_eq!(anim.name, "motion");
        assert_eq!(anim.frame_time, Some(doc.frame_time));
        assert_eq!(anim.frame_count(), doc.frames.len());
        // Sample from the rest pose so every animated value must come from the keys.
        let sampled = anim.sample(&rest.pose, k as f64 * doc.frame_time);
        for (j, (a, b)) in sampled.local.iter().zip(&expected.local).enumerate() {
            assert!((a.translation - b.translation).norm() < 1e-12, "joint {j}");
            assert!(a.rotation.angle_to(&b.rotation) < 1e-9, "joint {j}");
        }
        let sampled = anim.sample(&rig.pose, k as f64 * doc.frame_time);
        assert!(
            max_distance(
                &rig.skeleton.joint_positions(&sampled),
                &rig.skeleton.joint_positions(&expected)
            ) < 1e-9
        );
    }
    let rig = doc.to_rig(Some(0));
    let hips = rig.animations[0]
        .channels
        .iter()
        .filter(|c| c.joint == 0)
        .count();
    assert_eq!(hips, 2, "the root has rotation and translation channels");
    assert!(
        rig.animations[0]
            .channels
            .iter()
            .all(|c| !doc.joints[c.joint].end_site)
    );
}

#[test]
fn jacobian_matches_finite_differences_at_end_sites() {
    let (_, doc) = cmu();
    let skeleton = doc.skeleton();
    let pose = doc.pose_at_frame(100);
    let layout = DofLayout::new(&skeleton);
    let fk = ForwardKinematics::new(&skeleton, &pose);
    let h = 1e-6;
    let end_sites: Vec<usize> = (0..skeleton.len())
        .filter(|&j| skeleton.joint(j).kind == JointKind::EndSite)
        .collect();
    assert_eq!(
        end_sites.len(),
        doc.joints.iter().filter(|j| j.end_site).count()
    );
    assert!(!end_sites.is_empty());
    for &e in &end_sites {
        let p = fk.position(e);
        let mut analytic = vec![Vector3::zeros(); layout.len()];
        fk.point_jacobian(&layout, e, &p, |c, v| analytic[c] = v);
        let norm = analytic
            .iter()
            .map(|v| v.norm_squared())
            .sum::<f64>()
            .sqrt();
        assert!(norm > 1.0);
        let mut worst: f64 = 0.0;
        let numeric_columns =
            numeric_point_jacobian(&skeleton, &layout, &pose, e, &Point3::origin(), h);
        for (c, numeric) in numeric_columns.iter().enumerate() {
            worst = worst.max((numeric - analytic[c]).norm());
        }
        assert!(
            worst / norm < 1e-5,
            "{}: error {worst} against norm {norm}",
            skeleton.joint(e).name
        );
    }
}

/// A glTF-like rig: an armature helper with a rotation and a uniform scale, joints in
/// parents-first but not depth-first order, a leaf skin joint and an End Site.
fn gltf_like_skeleton() -> Skeleton {
    let t = |x: f64, y: f64, z: f64| Trs::from_translation(Vector3::new(x, y, z));
    let mut armature = Joint::new(
        "Armature",
        None,
        Trs {
            translation: Vector3::new(0.0, 0.0, 0.0),
            rotation: Quat::from_euler_angles(std::f64::consts::FRAC_PI_2, 0.0, 0.0),
            scale: Vector3::new(0.01, 0.01, 0.01),
        },
    );
    armature.kind = JointKind::Helper;
    let mut head_top = Joint::new("HeadTop", Some(4), t(0.0, 20.0, 0.0));
    head_top.kind = JointKind::EndSite;
    let mut left_arm = Joint::new("LeftArm", Some(2), t(15.0, 40.0, 0.0));
    left_arm.rest.rotation = Quat::from_euler_angles(0.0, 0.0, -1.2);
    let joints = vec![
        armature,
        Joint::new("mixamorig:Hips", Some(0), t(0.0, 0.0, 100.0)),
        Joint::new("Spine", Some(1), t(0.0, 10.0, 0.0)),
        Joint::new("LeftUpLeg", Some(1), t(10.0, -5.0, 0.0)),
        Joint::new("Head", Some(2), t(0.0, 50.0, 0.0)),
        Joint::new("LeftLeg", Some(3), t(0.0, -45.0, 0.0)),
        head_top,
        left_arm,
    ];
    let mut skeleton = Skeleton::new(joints).expect("valid");
    skeleton.set_default_dofs();
    skeleton
}

#[test]
fn from_skeleton_keeps_world_positions() {
    let skeleton = gltf_like_skeleton();
    let mut seed = 5u64;
    let mut poses = vec![skeleton.rest_pose()];
    for _ in 0..5 {
        let mut pose = skeleton.rest_pose();
        for (j, local) in pose.local.iter_mut().enumerate() {
            let w = Vector3::new(rand(&mut seed), rand(&mut seed), rand(&mut seed)) * 2.0;
            local.rotation *= Quat::from_scaled_axis(w);
            if j == 1 {
                local.translation += Vector3::new(rand(&mut seed), rand(&mut seed), 0.0) * 30.0;
            }
        }
        poses.push(pose);
    }
    let doc = BvhDocument::from_skeleton(&skeleton, &poses, 0.04);
    assert_eq!(doc.frames.len(), poses.len());
    assert_eq!(doc.joints.len(), skeleton.len());
    assert!(doc.joints[6].end_site && doc.joints[6].channels.is_empty());
    assert_eq!(
        doc.joints[1].channels.len(),
        6,
        "the free skin root gets positions"
    );
    assert_eq!(
        doc.joints[2].channels,
        [
            BvhChannel::Zrotation,
            BvhChannel::Xrotation,
            BvhChannel::Yrotation
        ]
    );
    assert_eq!(
        doc.joints[7].channels.len(),
        3,
        "a leaf skin joint is a JOINT"
    );
    // Same joint order as the skeleton: world positions match joint for joint.
    for (k, pose) in poses.iter().enumerate() {
        let expected = skeleton.joint_positions(pose);
        assert!(
            max_distance(&positions(&doc, k), &expected) < 1e-9,
            "frame {k}"
        );
    }
    // Through a file: written depth first, so match joints by name (the End Site is
    // renamed after its parent).
    let back = parse_bvh(doc.to_bvh_string().as_bytes()).expect("parses");
    let order: Vec<usize> = back
        .joints
        .iter()
        .map(|j| {
            let name = if j.end_site {
                "HeadTop"
            } else {
                j.name.as_str()
            };
            skeleton.find(name).expect("known joint")
        })
        .collect();
    assert_eq!(order, [0, 1, 2, 4, 6, 7, 3, 5]);
    assert_eq!(back.joints[4].name, "Head_End");
    for (k, pose) in poses.iter().enumerate() {
        let expected = skeleton.joint_positions(pose);
        let got = positions(&back, k);
        for (i, &o) in order.iter().enumerate() {
            assert!(
                (got[i] - expected[o]).norm() < 1e-9,
                "frame {k}, {}",
                back.joints[i].name
            );
        }
    }
    // No poses: a hierarchy without motion.
    let empty = BvhDocument::from_skeleton(&skeleton, &[], 0.04);
    assert!(empty.frames.is_empty());
    let reread = parse_bvh(empty.to_bvh_string().as_bytes()).expect("parses");
    assert!(reread.frames.is_empty());
    assert_eq!(reread.joints.len(), skeleton.len());
}

#[test]
fn from_skeleton_survives_non_uniform_scale() {
    let mut joints = vec![
        Joint::new("a", None, Trs::IDENTITY),
        Joint::new(
            "b",
            Some(0),
            Trs::from_translation(Vector3::new(0.0, 1.0, 0.0)),
        ),
    ];
    joints[0].rest.scale = Vector3::new(1.0, 2.0, 3.0);
    let skeleton = Skeleton::new(joints).expect("valid");
    let doc = BvhDocument::from_skeleton(&skeleton, &[skeleton.rest_pose()], 0.1);
    assert_eq!(doc.frames.len(), 1);
    assert!(parse_bvh(doc.to_bvh_string().as_bytes()).is_ok());
}

/// Every malformed sample fails with one line that says what is wrong.
#[test]
fn malformed_files_fail_with_clear_messages() {
    let dir = Path::new(env!("CARGO_MANIFEST_DIR")).join("tests/malformed");
    let cases = [
        (
            "bvh_wrong_value_count.bvh",
            "line 20: frame 1 has 8 values, expected 9",
        ),
        ("bvh_unknown_channel.bvh", "unknown channel \"Wrotation\""),
        (
            "bvh_truncated_hierarchy.bvh",
            "line 9: unexpected end of file inside joint \"Spine\" opened on line 6",
        ),
        ("bvh_missing_motion.bvh", "line 15: missing MOTION section"),
        (
            "bvh_nan_motion.bvh",
            "line 20: frame 1, value 5 (Hips Xrotation): \"NaN\" is not a finite number",
        ),
        ("bvh_infinite_motion.bvh", "is not a finite number"),
        ("bvh_non_numeric_motion.bvh", "\"9.x\" is not a number"),
        (
            "bvh_non_numeric_offset.bvh",
            "line 8: OFFSET of joint \"Spine\": \"five\" is not a number",
        ),
        (
            "bvh_channel_count_mismatch.bvh",
            "line 5: CHANNELS 7 of joint \"Hips\" lists only 6 channel names",
        ),
        ("bvh_unbalanced_braces.bvh", "line 16: unmatched '}'"),
        ("bvh_no_joints.bvh", "no ROOT joint"),
        (
            "bvh_huge_offset.bvh",
            "line 8: OFFSET of joint \"Spine\": \"1e308\" is too large (out of range",
        ),
    ];
    let mut seen = 0;
    for entry in std::fs::read_dir(&dir).expect("malformed dir") {
        let name = entry
            .expect("entry")
            .file_name()
            .to_string_lossy()
            .into_owned();
        if name.starts_with("bvh_") && name.ends_with(".bvh") {
            assert!(
                cases.iter().any(|(c, _)| *c == name),
                "{name} has no expectation"
            );
            seen += 1;
        }
    }
    assert_eq!(seen, cases.len());
    for (file, expected) in cases {
        let path = dir.join(file);
        let bytes = std::fs::read(&path).expect("sample");
        let message = parse_bvh(&bytes).expect_err(file).to_string();
        assert!(!message.contains('\n'), "{file}: {message}");
        assert!(
            message.contains(expected),
            "{file}: {message:?} lacks {expected:?}"
        );
        let with_path = read_bvh(&path).expect_err(file).to_string();
        assert!(!with_path.contains('\n'));
        assert!(
            with_path.contains(file) && with_path.contains(expected),
            "{with_path}"
        );
    }
    let missing = read_bvh(&dir.join("no_such_file.bvh")).expect_err("missing file");
    assert!(missing.to_string().contains("no_such_file.bvh"));
}

#[test]
fn more_malformed_inputs() {
    let cases: &[(&str, &str)] = &[
        ("", "empty file"),
        ("{\"nodes\": []}", "not a BVH file"),
        ("HIERARCHY\nROOT\n{\n", "line 2: ROOT without a name"),
        (
            "HIERARCHY\nROOT a\nOFFSET 0 0 0\n",
            "expected '{' after ROOT",
        ),
        (
            "HIERARCHY\nROOT a\n{\nCHANNELS 0\n}\nMOTION\n",
            "has no OFFSET",
        ),
        (
            "HIERARCHY\nROOT a\n{\nOFFSET 0 0\n}\n",
            "OFFSET of joint \"a\" needs 3 numbers",
        ),
        (
            "HIERARCHY\nROOT a\n{\nOFFSET 0 0 inf\n}\n",
            "is not a finite number",
        ),
        (
            "HIERARCHY\nROOT a\n{\nOFFSET 0 0 0\nCHANNELS 2 Xrotation Xrotation\n}\n",
            "listed twice",
        ),
        (
            "HIERARCHY\nROOT a\n{\nOFFSET 0 0 0\nCHANNELS x\n}\n",
            "expects a channel count",
        ),
        (
            "HIERARCHY\nROOT a\n{\nOFFSET 0 0 0\nMOTION\n",
            "MOTION inside joint \"a\"",
        ),
        (
            "HIERARCHY\nROOT a\n{\nOFFSET 0 0 0\nEnd Site\n{\nOFFSET 0 0 0\nCHANNELS 1 Xrotation\n}\n}\n",
            "cannot have channels",
        ),
        (
            "HIERARCHY\nROOT a\n{\nOFFSET 0 0 0\n}\nMOTION\nFrame Time: 1\n",
            "expected 'Frames:'",
        ),
        (
            "HIERARCHY\nROOT a\n{\nOFFSET 0 0 0\n}\nMOTION\nFrames: -1\nFrame Time: 1\n",
            "whole number",
        ),
        (
            "HIERARCHY\nROOT a\n{\nOFFSET 0 0 0\n}\nMOTION\nFrames: 1\nFrame Time: nan\n",
            "positive number",
        ),
        (
            "HIERARCHY\nROOT a\n{\nOFFSET 0 0 0\n}\nMOTION\nFrames: 1\n",
            "missing 'Frame Time:'",
        ),
        (
            "HIERARCHY\nROOT a\n{\nOFFSET 0 0 0\nCHANNELS 1 Xrotation\n}\nMOTION\nFrames: 1\nFrame Time: 1\n1 2\n",
            "line 10: frame 0 has 2 values, expected 1",
        ),
        (
            "HIERARCHY\nROOT a\n{\nOFFSET 0 0 0\n}\nMOTION\nFrames: 99999999999999\nFrame Time: 1\n",
            "too many",
        ),
    ];
    for (text, expected) in cases {
        let message = parse_bvh(text.as_bytes()).expect_err(text).to_string();
        assert!(!message.contains('\n'), "{message}");
        assert!(
            message.contains(expected),
            "{text:?}: {message:?} lacks {expected:?}"
        );
    }
    // A huge header count reserves nothing.
    let text = format!("{SMALL}Frames: 18446744073709551615\nFrame Time: 1\n0 0 0 0 0 0 0 0 0\n");
    assert_eq!(parse_bvh(text.as_bytes()).expect("parses").frames.len(), 1);
    let text = "HIERARCHY\nROOT a\n{\nOFFSET 0 0 0\nCHANNELS 18446744073709551615 Xrotation\n}\n";
    assert!(parse_bvh(text.as_bytes()).is_err());
}

/// Cut and corrupt files everywhere: the parser returns, never panics, and its errors are
/// one line.
#[test]
fn never_panics_on_damaged_input() {
    let text = format!("{SMALL}Frames: 2\nFrame Time: .5\n0 10 0 0 0 0 0 0 0\n1 2 3 4 5 6 7 8 9\n")
        .replace("Spine", "Spine:Ä b");
    let bytes = text.as_bytes();
    let check = |b: &[u8]| {
        if let Err(e) = parse_bvh(b) {
            let m = e.to_string();
            assert!(!m.contains('\n') && !m.contains('\r'), "{m:?}");
        }
    };
    for cut in 0..=bytes.len() {
        check(&bytes[..cut]);
    }
    let replacements = [
        b'{', b'}', b'\n', b'\r', b' ', b'x', b'9', b'-', b'.', 0, 0xff, 0xc3,
    ];
    for i in 0..bytes.len() {
        for &r in &replacements {
            let mut b = bytes.to_vec();
            b[i] = r;
            check(&b);
        }
        let mut removed = bytes.to_vec();
        removed.remove(i);
        check(&removed);
    }
    // Deep nesting does not overflow the stack.
    let deep = "JOINT j\n{\nOFFSET 0 0 0\n".repeat(100_000);
    check(format!("HIERARCHY\nROOT r\n{{\nOFFSET 0 0 0\n{deep}").as_bytes());
    // The real file cut at every line of its hierarchy.
    let (cmu_text, _) = cmu();
    let mut cut = 0;
    for line in cmu_text.lines().take(200) {
        cut += line.len() + 1;
        check(&cmu_text.as_bytes()[..cut.min(cmu_text.len())]);
    }
}

#[test]
fn pose_at_frame_is_safe_past_the_end() {
    let text = format!("{SMALL}Frames: 1\nFrame Time: 0.04\n0 10 0 0 0 0 0 0 0\n");
    let doc = parse_bvh(text.as_bytes()).expect("parses");
    assert_eq!(doc.pose_at_frame(5), doc.pose_at_frame(0));
    let rest_positions = doc.skeleton().joint_positions(&doc.rest_pose());
    assert!((rest_positions[2] - Point3::new(0.0, 10.0, 0.0)).norm() < 1e-12);
    let moved = positions(&doc, 0);
    assert!((moved[2] - Point3::new(0.0, 20.0, 0.0)).norm() < 1e-12);
    // Rotation order: Zrotation 90 then Xrotation 90 on the root maps the spine's +y
    // offset to Rz(90) * Rx(90) * (0, 5, 0) = Rz(90) * (0, 0, 5) = (0, 0, 5).
    let mut doc = doc;
    doc.frames[0] = vec![0.0, 0.0, 0.0, 90.0, 90.0, 0.0, 0.0, 0.0, 0.0];
    let p = positions(&doc, 0);
    assert!(
        (p[1] - Point3::new(0.0, 0.0, 5.0)).norm() < 1e-12,
        "{}",
        p[1]
    );
    doc.frames[0] = vec![0.0, 0.0, 0.0, 90.0, 0.0, 0.0, 0.0, 0.0, 0.0];
    let p = positions(&doc, 0);
    assert!(
        (p[1] - Point3::new(-5.0, 0.0, 0.0)).norm() < 1e-12,
        "{}",
        p[1]
    );
}
