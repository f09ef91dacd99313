//! Surface tracking on the many-part objects of the surface corpus (issue 22's table in
//! BENCHMARKS.md): each object posed through its joints by a fast motion, 30 scans of 8,000
//! points (0.5% noise, 15% outliers, a part unseen in frames 10-19), tracked from its
//! reference; per object and seed the mean, p95, worst frame mean and worst vertex (% of the
//! diagonal), the unseen part's error when it comes back, the time per frame, whether the
//! sequence is within the bar (mean <= 1.5%, p95 <= 4%, no frame over 3%, no vertex over
//! 10%), and the same four figures and bar on what the scans show (the unseen part left out
//! while it is unseen); then each half's counts within the bar.
//!
//! `cargo run --release -p rigfit-testkit --example surface_corpus`
//! (`SEEDS=N` seeds 0..N, default 1; `OBJECTS=id,id` some objects; `FAR_POSES=N` the motion
//! through N far poses instead of 6 (3: the pace, half as fast); `PAPER=1` the paper's
//! method; `FAST_MOTION=1` `SurfaceOptions::fast_motion`; `NO_LINKS=1` without contact
//! links; `NO_CARRY=1` without carrying unseen patches; `SIGMA`, `ANNEAL`, `ITERATIONS`,
//! `MERGE`, `TOLERANCE`, `STRIDE`, `CANDIDATES`, `CUTOFF`, `HOLD`, `COARSE_ITERATIONS`,
//! `FAST`, `COARSE_STIFFNESS`, `ANCHOR`, `STIFFNESS`, `CONTACT_WIDTH`, `PART_GAP`,
//! `POINTS_PER_VERTEX` set those
//! options; `NO_PIECE_TREE=1` without the pieces' tree, `TREE_POINTS`,
//! `TREE_POINTS_PER_PIECE`, `TREE_STRIDE`, `TREE_STEPS`, `TREE_FINAL`, `TREE_SIGMA`,
//! `TREE_PRIOR`, `TREE_PREDICTION`, `TREE_MOTION` its model points (at least, and a piece),
//! data stride, annealing steps, iterations at the floor, the patches' first kernel after
//! it, the weight of its prior toward each frame's start, the share of the last motion it
//! continues and its first kernel, `TREE_NOISE`, `TREE_TANGENTIAL`, `TREE_BENDING` its
//! narrowest kernel, the share of each pull along the surface and the skin's bending
//! exponent, `TREE_SECOND=1.0` the tree tracked from a
//! second prediction too and `TREE_CHOICE` the width choosing between the two; `RETURNING=0`
//! parts coming back into view not searched for; `REFIT_BELOW=R` a frame whose pieces' coverage
//! falls below R times the last frame's fitted again from other starts (`none`: never);
//! `FIRST_SEED=N` starts at seed N; `DRAWS=K` tracks each sequence with K draws of the
//! pieces' tree's model points (`PieceTreeOptions::model_points_seed`, draw 0 the default,
//! `FIRST_DRAW=D` from draw D; the seed cell then reads `seed/draw`) and prints each half's
//! counts and mean of means per draw and their average: the draw alone moves the counts by
//! several sequences, so a change is judged over several; `VERBOSE=1` every frame's mean
//! and worst vertex (and worst on what the scans show) and the truth's steps, `VERBOSE=2`
//! also each piece's mean and worst in the frame with the farthest vertex the scans show,
//! and which of the truth's pieces the worst piece lies on; `PLOT=DIR` writes
//! DIR/surface_parts_frames.png, each object's mean per frame, `_paper` with `PAPER=1`)

#[path = "common/env_knobs.rs"]
mod env_knobs;
#[path = "common/plot_file.rs"]
mod plot_file;

use rigfit_core::surface::SurfaceOptions;
use rigfit_core::track::MODEL_POINTS_SEED;
use rigfit_render::{Chart, Series, line_chart};
use rigfit_testkit::corpus::Half;
use rigfit_testkit::surface_corpus::{
    PartsCase, PartsOptions, PartsScore, load, parts_case, piece_labels, track_parts,
};

fn main() {
    let corpus = match load() {
        Ok(c) => c,
        Err(e) => {
            eprintln!("surface_corpus: {e}");
            std::process::exit(2);
        }
    };
    let seeds = env_knobs::count("SEEDS", 1) as u64;
    let chosen = env_knobs::names("OBJECTS");
    let mut options = if std::env::var("PAPER").is_ok() {
        SurfaceOptions::paper()
    } else if std::env::var("FAST_MOTION").is_ok() {
        SurfaceOptions::fast_motion()
    } else {
        SurfaceOptions::default()
    };
    // Options to compare against the defaults.
    env_knobs::set("SIGMA", &mut options.initial_sigma);
    env_knobs::set("ANNEAL", &mut options.anneal);
    env_knobs::set_count("ITERATIONS", &mut options.max_iterations);
    env_knobs::set("HOLD", &mut options.hold_while_moving);
    env_knobs::set("CUTOFF", &mut options.data.cutoff_sigmas);
    env_knobs::set_count("CANDIDATES", &mut options.data.max_candidates);
    env_knobs::set("MERGE", &mut options.merge_cell);
    env_knobs::set("TOLERANCE", &mut options.tolerance);
    env_knobs::set_count("STRIDE", &mut options.coarse_stride);
    env_knobs::set_count("COARSE_ITERATIONS", &mut options.coarse_iterations);
    env_knobs::set("COARSE_STIFFNESS", &mut options.coarse_stiffness);
    env_knobs::set("FAST", &mut options.fast_start);
    env_knobs::set("ANCHOR", &mut options.anchor);
    env_knobs::set("CONTACT_WIDTH", &mut options.patches.contact_width);
    env_knobs::set("PART_GAP", &mut options.patches.part_gap);
    env_knobs::set("STIFFNESS", &mut options.patches.contact_stiffness);
    env_knobs::set("POINTS_PER_VERTEX", &mut options.points_per_vertex);
    if let Some(tree) = options.piece_tree.as_mut() {
        env_knobs::set_count("TREE_POINTS", &mut tree.model_points);
        env_knobs::set_count("TREE_POINTS_PER_PIECE", &mut tree.model_points_per_piece);
        env_knobs::set_count("TREE_STRIDE", &mut tree.data_stride);
        env_knobs::set_count("TREE_STEPS", &mut tree.track.anneal_steps);
        env_knobs::set_count("TREE_FINAL", &mut tree.track.final_em_iterations);
        env_knobs::set("TREE_SIGMA", &mut tree.initial_sigma);
        env_knobs::set("TREE_CHOICE", &mut tree.choice_sigma);
        env_knobs::set("TREE_PRIOR", &mut tree.track.prior_weight);
        env_knobs::set("TREE_PREDICTION", &mut tree.track.prediction);
        env_knobs::set("TREE_MOTION", &mut tree.track.max_motion);
        env_knobs::set("TREE_NOISE", &mut tree.track.noise);
        env_knobs::set("TREE_TANGENTIAL", &mut tree.track.tangential);
        env_knobs::set("TREE_BENDING", &mut tree.track.bending_exponent);
        if let Ok(v) = std::env::var("RETURNING") {
            tree.find_returning_parts = v != "0";
        }
        if let Ok(v) = std::env::var("REFIT_BELOW") {
            tree.refit_below = v.parse().ok();
        }
        if let Ok(v) = std::env::var("TREE_SECOND") {
            tree.second_prediction = v.parse().ok();
        }
    }
    if std::env::var("NO_PIECE_TREE").is_ok() {
        options.piece_tree = None;
    }
    if std::env::var("NO_CARRY").is_ok() {
        options.carry_unseen = false;
    }
    if std::env::var("NO_LINKS").is_ok() {
        options.patches.link_parts = false;
    }
    let verbose = std::env::var("VERBOSE").is_ok();
    let mut parts = PartsOptions::default();
    env_knobs::set_count("FAR_POSES", &mut parts.far_poses);
    println!(
        "| object | half | seed | pieces | vertices | mean | p95 | worst frame | worst vertex | unseen part back (mean / worst) | ms/frame | bar | seen: mean / p95 / worst frame / worst vertex | bar, seen |"
    );
    println!("|---|---|---|---|---|---|---|---|---|---|---|---|---|---|");
    let draws = env_knobs::count("DRAWS", 1).max(1) as u64;
    let first_draw = env_knobs::count("FIRST_DRAW", 0) as u64;
    // Per half and draw: sequences within the bar, within it on what the scans show, all
    // sequences, and the sum of their means.
    let mut tally = std::collections::BTreeMap::<(Half, u64), Tally>::new();
    let mut curves: Vec<Series> = Vec::new();
    for entry in &corpus.rigs {
        if chosen.as_ref().is_some_and(|c| !c.contains(&entry.id)) {
            continue;
        }
        for seed in env_knobs::count("FIRST_SEED", 0) as u64..seeds {
            let case = match parts_case(&corpus, entry, seed, &parts) {
                Ok(c) => c,
                Err(e) => {
                    eprintln!("{e}");
                    continue;
                }
            };
            if verbose {
                print_truth_steps(&entry.id, seed, &case);
            }
            // The pieces of the reference, for `VERBOSE=2` (the same for every draw).
            let labels = std::env::var("VERBOSE")
                .is_ok_and(|v| v == "2")
                .then(|| piece_labels(&case.sequence.reference, 1e-7 * case.sequence.diagonal));
            for draw in first_draw..first_draw + draws {
                let label = if draws > 1 || first_draw > 0 {
                    format!("{seed}/{draw}")
                } else {
                    seed.to_string()
                };
                if let Some(tree) = options.piece_tree.as_mut() {
                    tree.model_points_seed = MODEL_POINTS_SEED.wrapping_add(draw);
                }
                let score = match track_parts(&case, &options, parts.scan.hole_frames.clone()) {
                    Ok(s) => s,
                    Err(e) => {
                        println!(
                            "| {} | {} | {label} | failed: {e} |",
                            entry.id,
                            entry.half.name()
                        );
                        tally.entry((entry.half, draw)).or_default().total += 1;
                        continue;
                    }
                };
                if verbose {
                    let reference = &case.sequence.reference;
                    for (f, (m, w)) in score.frame_means.iter().zip(&score.frame_worst).enumerate()
                    {
                        let v = score.frame_worst_vertex[f];
                        eprintln!(
                            "{} seed {label} frame {f}: mean {:.2}% worst {:.2}% (vertex {v} at {:.3?}) seen {:.2}%",
                            entry.id,
                            m * 100.0,
                            w * 100.0,
                            reference.vertices[v].coords.as_slice(),
                            score.frame_worst_seen[f] * 100.0
                        );
                    }
                }
                if let Some(labels) = &labels {
                    print_worst_piece(&entry.id, &label, &case, &score, labels);
                }
                curves.push(Series::new(
                    format!("{} ({})", entry.id, entry.half.name()),
                    score
                        .frame_means
                        .iter()
                        .enumerate()
                        .map(|(f, m)| (f as f64, m * 100.0))
                        .collect(),
                ));
                let pass = score.passes();
                let t = tally.entry((entry.half, draw)).or_default();
                t.within += usize::from(pass);
                t.within_seen += usize::from(score.seen.passes());
                t.total += 1;
                t.sum_of_means += score.mean;
                let back = match (score.returned, score.returned_worst) {
                    (Some(m), Some(w)) => format!("{:.2} / {:.2}", m * 100.0, w * 100.0),
                    _ => "-".into(),
                };
                println!(
                    "| {} | {} | {label} | {} | {} | {:.2} | {:.2} | {:.2} | {:.2} | {back} | {:.1} | {} | {:.2} / {:.2} / {:.2} / {:.2} | {} |",
                    entry.id,
                    entry.half.name(),
                    case.pieces,
                    case.sequence.reference.vertices.len(),
                    score.mean * 100.0,
                    score.p95 * 100.0,
                    score.worst_frame() * 100.0,
                    score.worst_vertex() * 100.0,
                    score.median_seconds() * 1000.0,
                    if pass { "yes" } else { "no" },
                    score.seen.mean * 100.0,
                    score.seen.p95 * 100.0,
                    score.seen.worst_frame * 100.0,
                    score.seen.worst_vertex * 100.0,
                    if score.seen.passes() { "yes" } else { "no" }
                );
            }
        }
    }
    print_tally(&tally);
    if let Ok(dir) = std::env::var("PLOT") {
        let paper = std::env::var("PAPER").is_ok();
        let mut chart = Chart::new(
            if paper {
                "Many-part objects: mean vertex error per frame, the paper's method"
            } else {
                "Many-part objects: mean vertex error per frame (rigfit)"
            },
            "frame (a part unseen in frames 10-19)",
            "mean error (% of the diagonal)",
        );
        chart.y_log = true;
        chart.series = curves;
        let name = if paper {
            "surface_parts_frames_paper.png"
        } else {
            "surface_parts_frames.png"
        };
        std::fs::create_dir_all(&dir).expect("the plot folder");
        plot_file::write(&line_chart(&chart), std::path::Path::new(&dir), name);
    }
}

/// One half's sequences under one draw of the tree's model points.
#[derive(Clone, Copy, Debug, Default)]
struct Tally {
    within: usize,
    within_seen: usize,
    total: usize,
    sum_of_means: f64,
}

/// Each half's counts within the bar (and on what the scans show) and its mean of the
/// sequences' means: per draw, then their average when there are several.
fn print_tally(tally: &std::collections::BTreeMap<(Half, u64), Tally>) {
    let mut halves: Vec<Half> = tally.keys().map(|&(h, _)| h).collect();
    halves.dedup();
    for half in halves {
        let draws: Vec<(u64, Tally)> = tally
            .iter()
            .filter(|&(&(h, _), _)| h == half)
            .map(|(&(_, d), &t)| (d, t))
            .collect();
        let mean = |t: &Tally| 100.0 * t.sum_of_means / t.total.max(1) as f64;
        if let [(_, t)] = draws[..] {
            println!(
                "{}: {}/{} within the bar ({}/{} on what the scans show), mean of means {:.3}%",
                half.name(),
                t.within,
                t.total,
                t.within_seen,
                t.total,
                mean(&t)
            );
            continue;
        }
        for (d, t) in &draws {
            println!(
                "{} draw {d}: {}/{} within the bar ({} on what the scans show), mean of means {:.3}%",
                half.name(),
                t.within,
                t.total,
                t.within_seen,
                mean(t)
            );
        }
        let n = draws.len() as f64;
        let average = |f: &dyn Fn(&Tally) -> f64| draws.iter().map(|(_, t)| f(t)).sum::<f64>() / n;
        println!(
            "{} over {} draws: {:.1}/{} within the bar ({:.1} on what the scans show), mean of means {:.3}%",
            half.name(),
            draws.len(),
            average(&|t| t.within as f64),
            draws[0].1.total,
            average(&|t| t.within_seen as f64),
            average(&|t| mean(t))
        );
    }
}

/// The truth's steps between frames of `case`: each frame's mean and largest vertex step,
/// fractions of the diagonal.
fn print_truth_steps(id: &str, seed: u64, case: &PartsCase) {
    let truth = &case.sequence.truth;
    for f in 1..truth.len() {
        let steps: Vec<f64> = truth[f]
            .iter()
            .zip(&truth[f - 1])
            .map(|(a, b)| (a - b).norm() / case.sequence.diagonal)
            .collect();
        let mean = steps.iter().sum::<f64>() / steps.len() as f64;
        let max = steps.iter().copied().fold(0.0, f64::max);
        eprintln!(
            "{id} seed {seed} truth step {f}: mean {:.2}% max {:.2}%",
            mean * 100.0,
            max * 100.0
        );
    }
}

/// Each piece's (`labels`) mean and farthest error in the frame with the farthest vertex the
/// scans show, and which of the truth's pieces the worst piece lies on.
fn print_worst_piece(id: &str, label: &str, case: &PartsCase, score: &PartsScore, labels: &[u32]) {
    let mut pieces = std::collections::BTreeMap::<u32, (usize, usize, f64, f64)>::new();
    for (v, &l) in labels.iter().enumerate() {
        let e = pieces.entry(l).or_insert((v, 0, 0.0, 0.0));
        let error = score.worst_vertex_frame_errors[v];
        e.1 += 1;
        e.2 += error;
        e.3 = e.3.max(error);
    }
    // Where the worst piece lies: each of its vertices' nearest true vertex's piece.
    let worst_piece = labels[score
        .worst_vertex_frame_errors
        .iter()
        .enumerate()
        .fold((0, 0.0), |a, (i, &e)| if e > a.1 { (i, e) } else { a })
        .0];
    let truth = &case.sequence.truth[score.worst_vertex_frame];
    let mut lies_on = std::collections::BTreeMap::<u32, usize>::new();
    for (v, p) in score.worst_vertex_frame_fit.iter().enumerate() {
        if labels[v] != worst_piece {
            continue;
        }
        let nearest = truth
            .iter()
            .enumerate()
            .map(|(u, q)| (u, (p - q).norm()))
            .fold((0, f64::MAX), |a, b| if b.1 < a.1 { b } else { a });
        *lies_on.entry(labels[nearest.0]).or_default() += 1;
    }
    let first_of = |l: u32| labels.iter().position(|&m| m == l).unwrap_or(0);
    eprintln!(
        "{id} seed {label} frame {}: the worst piece (from vertex {}) lies on the truth's pieces {:?}",
        score.worst_vertex_frame,
        first_of(worst_piece),
        lies_on
            .iter()
            .map(|(&l, &n)| (first_of(l), n))
            .collect::<Vec<_>>()
    );
    for (first, count, sum, worst) in pieces.values() {
        eprintln!(
            "{id} seed {label} worst vertex's frame: piece from vertex {first} ({count} vertices): mean {:.2}% worst {:.2}%",
            sum / *count as f64 * 100.0,
            worst * 100.0
        );
    }
}
