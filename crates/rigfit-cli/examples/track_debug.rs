#[path = "../tests/common/track_suites.rs"]
mod track_suites;
use rigfit_core::track::cases::SequenceOptions;
use rigfit_core::track::{TrackOptions, Tracker};
use rigfit_core::engine::PointGrid;
fn main() {
    tracing_subscriber::fmt().with_env_filter(tracing_subscriber::EnvFilter::new("debug")).init();
    let name: &'static str = Box::leak(std::env::args().nth(1).unwrap().into_boxed_str());
    let env = |k: &str, d: f64| std::env::var(k).ok().and_then(|v| v.parse().ok()).unwrap_or(d);
    let s = track_suites::suite(name, env("FRAMES", 3.0) as usize, &SequenceOptions { outliers: env("OUT", 0.25), noise: env("NOISE", 0.01), cameras: env("CAM", 2.0) as usize, ..Default::default() });
    let h = s.model.height;
    if std::env::var("TRUTH").is_ok() {
        for (k, f) in s.frames.iter().enumerate().take(4) {
            let p = s.rig.skeleton.joint_positions(&f.truth);
            println!("truth {k}: hips {:?} err-vs-rigpose {:.4}", p[0], track_suites::joint_error(&s.rig, &f.truth, &s.rig.pose, h));
        }
    }
    println!("height {h} parts {} samples {}", s.model.parts.parts.len(), s.model.surface_samples.len());
    for (j, joint) in s.rig.skeleton.joints().iter().enumerate().take(5) { println!("{j} {} {:?} {:?}", joint.name, joint.dof, joint.kind); }
    let opts = TrackOptions { max_motion: env("MOTION", 0.08), anneal_steps: env("STEPS", 5.0) as usize, prior_weight: env("PRIOR", 0.02), coarse_to_fine: env("COARSE", 1.0) > 0.0, predict_motion: env("PRED", 1.0) > 0.0, visible_only: env("VIS", 1.0) > 0.0, point_to_plane: env("P2P", 1.0) > 0.0, surface_fit_steps: env("SURF", 0.0) as usize, final_em_iterations: env("FINAL", 4.0) as usize, gauss_newton_steps: env("GN", 1.0) as usize, em_iterations: env("EMIT", 2.0) as usize, noise: env("SMIN", 0.01), bending_exponent: env("BEND", 2.0), ..TrackOptions::default() };
    let mut tracker = Tracker::new(s.model.clone(), opts).unwrap();
    tracker.set_pose(&s.frames[0].truth);
    let tex = tracker.texture_positions();
    let grid = PointGrid::new(&tex, 0.05 * h);
    let f = &s.frames[0];
    let mut d: Vec<f64> = f.points.iter().zip(&f.outlier).filter(|(_, o)| !**o).map(|(p, _)| grid.nearest_within(p, 0.5 * h).map_or(1.0, |x| x.1.sqrt() / h)).collect();
    d.sort_by(f64::total_cmp);
    println!("data->texture nearest: median {:.4} p90 {:.4}", d[d.len()/2], d[d.len()*9/10]);
    let b1 = rigfit_core::Aabb::from_points(&tex).unwrap();
    let b2 = rigfit_core::Aabb::from_points(f.points.iter().zip(&f.outlier).filter(|(_, o)| !**o).map(|(p,_)| p)).unwrap();
    println!("tex {:?} {:?}\ndata {:?} {:?}", b1.min, b1.max, b2.min, b2.max);
    let fit = tracker.track(&f.points).unwrap();
    println!("inliers {} err {:.4}", fit.inliers, track_suites::joint_error(&s.rig, &fit.pose, &f.truth, h));
    if std::env::var("JOINTS").is_ok() { per_joint(&s.rig, &fit.pose, &f.truth, h); }
    let mut errs = Vec::new();
    let t0 = std::time::Instant::now();
    let static_frames: Vec<_> = (0..60).map(|_| s.frames[0].clone()).collect();
    let frames: &[rigfit_core::track::cases::SequenceFrame] = if std::env::var("STATIC").is_ok() { &static_frames } else { &s.frames[1..] };
    let mut prev_truth = s.frames[0].truth.clone();
    for f in frames {
        let fit = tracker.track(&f.points).unwrap();
        errs.push(track_suites::joint_error(&s.rig, &fit.pose, &f.truth, h));
        if std::env::var("EACH").is_ok() { println!("  {:.4} {} motion {:.4}", errs.last().unwrap(), fit.inliers, track_suites::joint_error(&s.rig, &f.truth, &prev_truth, h)); }
        prev_truth = f.truth.clone();
    }
    if std::env::var("JOINTS").is_ok() { per_joint(&s.rig, tracker.pose(), &s.frames.last().unwrap().truth, h); }
    if !errs.is_empty() {
        println!("seq mean {:.4} worst {:.4} ms/frame {:.2}", errs.iter().sum::<f64>() / errs.len() as f64, errs.iter().cloned().fold(0.0, f64::max), t0.elapsed().as_secs_f64() * 1000.0 / errs.len() as f64);
    }
}
#[allow(dead_code)]
fn per_joint(rig: &rigfit_core::Rig, a: &rigfit_core::Pose, b: &rigfit_core::Pose, h: f64) {
    let pa = rig.skeleton.joint_positions(a);
    let pb = rig.skeleton.joint_positions(b);
    let mut v: Vec<(f64, &str)> = rig.reported_joints().map(|j| ((pa[j] - pb[j]).norm() / h, rig.skeleton.joint(j).name.as_str())).collect();
    v.sort_by(|x, y| y.0.total_cmp(&x.0));
    let k: usize = std::env::var("TOP").ok().and_then(|v| v.parse().ok()).unwrap_or(12);
    for (e, n) in v.iter().take(k) { println!("  {n}: {:.3}", e); }
}
