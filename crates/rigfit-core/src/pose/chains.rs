//! The chain step: a stroke is an ordered polyline, so it covers one connected chain of
//! bones in order. Each stroke gets the chain (and direction) whose arclength-matched points
//! lie closest to it at the current pose and whose length is closest to the stroke's;
//! strokes that share no bones are assigned greedily, best first. Points along an assigned
//! chain are then pulled to the stroke point at the same fraction of arclength, which has no
//! local minima of the kind nearest-point matching falls into.

use super::Solver;
use crate::kinematics::ForwardKinematics;
use crate::math::Point3;

/// Samples compared per stroke and chain.
const SAMPLES: usize = 24;
/// Chains more than this much longer or shorter (relative) than a stroke are not candidates.
const MAX_LENGTH_MISMATCH: f64 = 0.6;
/// Weight of the relative length mismatch against the mean squared distance (in heights).
const LENGTH_WEIGHT: f64 = 0.1;

/// The point at normalised arclength `u` of a polyline with cumulative lengths `cum`.
pub(super) fn at(line: &[Point3], cum: &[f64], u: f64) -> Point3 {
    let total = *cum.last().unwrap_or(&0.0);
    if total <= 0.0 || line.len() < 2 {
        return line[0];
    }
    let target = u.clamp(0.0, 1.0) * total;
    let seg = cum
        .partition_point(|&c| c < target)
        .clamp(1, line.len() - 1)
        - 1;
    let (a, b) = (cum[seg], cum[seg + 1]);
    let t = if b > a { (target - a) / (b - a) } else { 0.0 };
    line[seg] + (line[seg + 1] - line[seg]) * t
}

pub(super) fn cumulative(line: &[Point3]) -> Vec<f64> {
    let mut c = Vec::with_capacity(line.len());
    let mut acc = 0.0;
    c.push(0.0);
    for w in line.windows(2) {
        acc += (w[1] - w[0]).norm();
        c.push(acc);
    }
    c
}

/// The samples of stroke `s`, in order.
pub(super) fn stroke_points(solver: &Solver, s: usize) -> Vec<Point3> {
    solver.data[solver.stroke_ranges[s].clone()].to_vec()
}

/// A stroke's chain: bones from the chain's root end to its tip, and whether the stroke was
/// drawn tip first.
pub(super) type Assignment = Option<(Vec<usize>, bool)>;

/// For each stroke not `excluded`, its chain (`None` when no free chain is left for it).
pub(super) fn assign(solver: &Solver, chains: &[Vec<usize>], excluded: &[bool]) -> Vec<Assignment> {
    let candidates = candidates(solver, chains, excluded);
    greedy(
        solver,
        chains,
        &candidates,
        &vec![None; excluded.len()],
        excluded,
    )
}

/// Candidate chains per stroke at the current pose: (cost, chain index, reversed), best first.
pub(super) type Candidates = Vec<Vec<(f64, usize, bool)>>;

/// The candidates of every stroke not `excluded`.
pub(super) fn candidates(solver: &Solver, chains: &[Vec<usize>], excluded: &[bool]) -> Candidates {
    let model = &solver.model;
    let h = solver.height;
    let fk = ForwardKinematics::new(solver.skeleton, &solver.pose);
    // Each chain sampled at the same fractions of arclength as the strokes.
    let samples: Vec<(Vec<Point3>, f64)> = chains
        .iter()
        .map(|c| {
            let line = model.chain_polyline(c, &fk);
            let cum = cumulative(&line);
            let len: f64 = c.iter().map(|&b| model.bones[b].length).sum();
            let xs = (0..SAMPLES)
                .map(|i| at(&line, &cum, i as f64 / (SAMPLES - 1) as f64))
                .collect();
            (xs, len)
        })
        .collect();
    // Where a chain attaches moves little with the pose; its tip moves most: the comparison
    // weighs the attached end more.
    let weight = |along: f64| 1.2 - along;
    let weight_sum: f64 = (0..SAMPLES)
        .map(|i| weight(i as f64 / (SAMPLES - 1) as f64))
        .sum();
    let strokes = solver.stroke_allowed.len();
    // Candidates per stroke: (cost, chain index, reversed), best first.
    let mut candidates: Vec<Vec<(f64, usize, bool)>> = vec![Vec::new(); strokes];
    for s in (0..strokes).filter(|&s| !excluded[s]) {
        // Comparing every stroke with every chain is the solver's widest loop: an interrupt
        // leaves the remaining strokes without candidates (nothing more is assigned).
        if solver.interrupt.is_set() {
            break;
        }
        let stroke = stroke_points(solver, s);
        let scum = cumulative(&stroke);
        let stroke_len = *scum.last().unwrap_or(&0.0);
        let ys: Vec<Point3> = (0..SAMPLES)
            .map(|i| at(&stroke, &scum, i as f64 / (SAMPLES - 1) as f64))
            .collect();
        let list = &mut candidates[s];
        for (c, chain) in chains.iter().enumerate() {
            if !solver.stroke_may_cover(s, chain) {
                continue;
            }
            let (xs, len) = &samples[c];
            let mismatch = (stroke_len - len) / len.max(1e-12);
            if mismatch.abs() > MAX_LENGTH_MISMATCH {
                continue;
            }
            let length_term = LENGTH_WEIGHT * mismatch * mismatch;
            for reversed in [false, true] {
                let mut cost = 0.0;
                for (i, y) in ys.iter().enumerate() {
                    let k = if reversed { SAMPLES - 1 - i } else { i };
                    cost += weight(k as f64 / (SAMPLES - 1) as f64) * (y - xs[k]).norm_squared();
                }
                list.push((cost / weight_sum / (h * h) + length_term, c, reversed));
            }
        }
        list.sort_by(|a, b| a.0.total_cmp(&b.0));
    }
    candidates
}

/// Greedy assignment: strokes with a `fixed` chain keep it; the others take, best first, the
/// best candidate whose bones are still free.
pub(super) fn greedy(
    solver: &Solver,
    chains: &[Vec<usize>],
    candidates: &Candidates,
    fixed: &[Assignment],
    excluded: &[bool],
) -> Vec<Assignment> {
    let strokes = candidates.len();
    let mut used = vec![false; solver.model.bones.len()];
    let mut result: Vec<Assignment> = fixed.to_vec();
    let mut done: Vec<bool> = excluded.to_vec();
    for (s, f) in fixed.iter().enumerate() {
        if let Some((chain, _)) = f {
            done[s] = true;
            for &b in chain {
                used[b] = true;
            }
        }
    }
    // Each stroke's first candidate that may still be free: bones only ever become used, so
    // a candidate passed over never comes back (the scan is linear in the candidates).
    let mut first_free = vec![0usize; strokes];
    loop {
        // The unassigned stroke whose best still-free chain fits best.
        let mut pick: Option<(f64, usize, usize, bool)> = None;
        for s in 0..strokes {
            if done[s] {
                continue;
            }
            let list = &candidates[s];
            let skip = list[first_free[s]..]
                .iter()
                .position(|&(_, c, _)| chains[c].iter().all(|&b| !used[b]))
                .unwrap_or(list.len() - first_free[s]);
            first_free[s] += skip;
            let free = list.get(first_free[s]);
            match free {
                Some(&(cost, c, rev)) if pick.is_none_or(|p| cost < p.0) => {
                    pick = Some((cost, s, c, rev))
                }
                Some(_) => {}
                None => done[s] = true,
            }
        }
        let Some((_, s, c, reversed)) = pick else {
            break;
        };
        done[s] = true;
        for &b in &chains[c] {
            used[b] = true;
        }
        result[s] = Some((chains[c].clone(), reversed));
    }
    result
}

/// The arclength of stroke `s` (after resampling).
pub(super) fn stroke_length(solver: &Solver, s: usize) -> f64 {
    *cumulative(&stroke_points(solver, s)).last().unwrap_or(&0.0)
}

/// Whether stroke `s` runs along `chain` tip first (the direction whose arclength-matched
/// points lie closer at the current pose).
pub(super) fn better_direction(solver: &Solver, s: usize, chain: &[usize]) -> bool {
    let fk = ForwardKinematics::new(solver.skeleton, &solver.pose);
    let line = solver.model.chain_polyline(chain, &fk);
    let stroke = stroke_points(solver, s);
    let (lcum, scum) = (cumulative(&line), cumulative(&stroke));
    let cost = |reversed: bool| -> f64 {
        (0..SAMPLES)
            .map(|i| {
                let u = i as f64 / (SAMPLES - 1) as f64;
                (at(&stroke, &scum, u) - at(&line, &lcum, if reversed { 1.0 - u } else { u }))
                    .norm_squared()
            })
            .sum()
    };
    cost(true) < cost(false)
}

/// RMS distance (in heights) of each assigned stroke's points to the chain at the same
/// fraction of arclength, at the current pose.
pub(super) fn stroke_residuals(solver: &Solver, assignment: &[Assignment]) -> Vec<f64> {
    let fk = ForwardKinematics::new(solver.skeleton, &solver.pose);
    assignment
        .iter()
        .enumerate()
        .map(|(s, a)| {
            let Some((chain, reversed)) = a else {
                return 0.0;
            };
            let mut stroke = stroke_points(solver, s);
            if *reversed {
                stroke.reverse();
            }
            let line = solver.model.chain_polyline(chain, &fk);
            let (scum, lcum) = (cumulative(&stroke), cumulative(&line));
            let sum: f64 = (0..SAMPLES)
                .map(|i| {
                    let u = i as f64 / (SAMPLES - 1) as f64;
                    (at(&stroke, &scum, u) - at(&line, &lcum, u)).norm_squared()
                })
                .sum();
            (sum / SAMPLES as f64).sqrt() / solver.height
        })
        .collect()
}

/// For each model point on an assigned chain, the stroke point at the same fraction of
/// arclength (bone lengths give the model's fractions), with weight 1.
pub(super) fn arclength_targets(
    solver: &Solver,
    assignment: &[Assignment],
) -> Vec<Option<(Point3, f64)>> {
    let model = &solver.model;
    let mut targets = vec![None; model.points.len()];
    for (s, chain) in assignment.iter().enumerate() {
        let Some((chain, reversed)) = chain else {
            continue;
        };
        let mut stroke = stroke_points(solver, s);
        if *reversed {
            stroke.reverse();
        }
        let cum = cumulative(&stroke);
        // The stroke now runs from the chain's root end to its tip.
        let total: f64 = chain.iter().map(|&b| model.bones[b].length).sum();
        let mut before = 0.0;
        for &b in chain {
            let bone = &model.bones[b];
            let range = model.bone_points[b].clone();
            let n = range.len() as f64;
            for (idx, k) in range.enumerate() {
                let t = (idx as f64 + 0.5) / n;
                let u = (before + t * bone.length) / total.max(1e-12);
                targets[k] = Some((at(&stroke, &cum, u), 1.0));
            }
            before += bone.length;
        }
    }
    targets
}
