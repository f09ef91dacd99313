//! Debug one posing case: `pose_debug SUITE_INDEX CASE_INDEX`.
use std::path::PathBuf;

use rand::SeedableRng;
use rigfit_core::pose::cases::{CaseOptions, make_case, mean_joint_error};
use rigfit_core::pose::{PoseOptions, PoseProblem, solve_pose};
use rigfit_formats::rig_file::{RigOptions, StartFrame, read_rig};

fn main() {
    let args: Vec<String> = std::env::args().collect();
    let file = args.get(1).cloned().unwrap_or("cmu/01_01.bvh".into());
    let t: usize = args.get(2).and_then(|s| s.parse().ok()).unwrap_or(1);
    let drop: usize = args.get(3).and_then(|s| s.parse().ok()).unwrap_or(0);
    let stray: usize = args.get(4).and_then(|s| s.parse().ok()).unwrap_or(0);
    let root = concat!(env!("CARGO_MANIFEST_DIR"), "/../../../shared/data");
    let bvh = read_rig(
        &PathBuf::from(root).join(&file),
        &RigOptions {
            start_frame: StartFrame::Rest,
            ..Default::default()
        },
    )
    .expect("rig");
    let rig = &bvh.rig;
    let anim = &rig.animations[0];
    let truth = if file.ends_with("bvh") {
        let frames = anim.frame_count();
        anim.sample(
            &rig.pose,
            (t * (frames - 1) / 9) as f64 * anim.frame_time.unwrap_or(1.0 / 120.0),
        )
    } else {
        let (s, e) = (anim.start(), anim.end());
        anim.sample(&rig.pose, s + (e - s) * (t as f64 + 0.5) / 5.0)
    };
    let height = rig.height();
    let mut rng = rand::rngs::StdRng::seed_from_u64(1000 + t as u64);
    let case = make_case(
        &rig.skeleton,
        &truth,
        height,
        &CaseOptions {
            drop_limbs: drop,
            stray_strokes: stray,
            ..Default::default()
        },
        &mut rng,
    );
    let problem = PoseProblem {
        skeleton: &rig.skeleton,
        start: &rig.pose,
        strokes: &case.strokes,
        movable: None,
        height,
    };
    let result = solve_pose(&problem, &PoseOptions::default()).expect("solves");
    let name = |j: usize| rig.skeleton.joint(j).name.clone();
    for (s, chain) in case.stroke_chains.iter().enumerate() {
        let truth_names: Vec<String> = chain.iter().map(|&j| name(j)).collect();
        let got: Vec<String> = result.stroke_bones[s].iter().map(|&j| name(j)).collect();
        println!("stroke {s}: truth {truth_names:?}\n          got   {got:?}");
    }
    let err = mean_joint_error(
        &rig.skeleton,
        &result.pose,
        &truth,
        &case.drawn_joints,
        height,
    );
    println!("height {height:.2} error {:.2}%", err * 100.0);
    let a = rig.skeleton.joint_positions(&result.pose);
    let b = rig.skeleton.joint_positions(&truth);
    for &j in &case.drawn_joints {
        println!(
            "  {:>16} {:6.2}%",
            name(j),
            (a[j] - b[j]).norm() / height * 100.0
        );
    }
}
