//! The chain step: a stroke is an ordered polyline, so it covers one connected chain of
//! bones in order. Each stroke gets the chain (and direction) whose arclength-matched points
//! lie closest to it at the current pose; strokes that share no bones are assigned greedily,
//! best first; a stroke no chain explains is a stray.

use super::Solver;
use crate::kinematics::ForwardKinematics;
use crate::math::Point3;

/// Samples compared per stroke and chain.
const SAMPLES: usize = 24;
/// Longest chain one stroke may cover, in bones.
const MAX_CHAIN: usize = 12;

/// The point at normalised arclength `u` of a polyline with cumulative lengths `cum`.
fn at(line: &[Point3], cum: &[f64], u: f64) -> Point3 {
    let total = *cum.last().unwrap_or(&0.0);
    if total <= 0.0 || line.len() < 2 {
        return line[0];
    }
    let target = u * total;
    let seg = cum
        .partition_point(|&c| c < target)
        .clamp(1, line.len() - 1)
        - 1;
    let (a, b) = (cum[seg], cum[seg + 1]);
    let t = if b > a { (target - a) / (b - a) } else { 0.0 };
    line[seg] + (line[seg + 1] - line[seg]) * t
}

fn cumulative(line: &[Point3]) -> Vec<f64> {
    let mut c = Vec::with_capacity(line.len());
    let mut acc = 0.0;
    c.push(0.0);
    for w in line.windows(2) {
        acc += (w[1] - w[0]).norm();
        c.push(acc);
    }
    c
}

/// For each stroke, its chain of bones in stroke order, or `None` for a stray.
pub(super) fn assign(solver: &Solver) -> Vec<Option<Vec<usize>>> {
    let model = &solver.model;
    let fk = ForwardKinematics::new(solver.skeleton, &solver.pose);
    let chains = model.chains(MAX_CHAIN);
    let lines: Vec<(Vec<Point3>, Vec<f64>)> = chains
        .iter()
        .map(|c| {
            let l = model.chain_polyline(c, &fk);
            let cum = cumulative(&l);
            (l, cum)
        })
        .collect();
    let strokes = solver.stroke_allowed.len();
    // Candidates per stroke: (mean squared distance, chain index, reversed), best first.
    let mut candidates: Vec<Vec<(f64, usize, bool)>> = Vec::with_capacity(strokes);
    for s in 0..strokes {
        let stroke: Vec<Point3> = solver
            .data
            .iter()
            .zip(&solver.data_stroke)
            .filter(|(_, d)| **d == s)
            .map(|(p, _)| *p)
            .collect();
        let scum = cumulative(&stroke);
        let ys: Vec<Point3> = (0..SAMPLES)
            .map(|i| at(&stroke, &scum, i as f64 / (SAMPLES - 1) as f64))
            .collect();
        let mut list = Vec::new();
        for (c, chain) in chains.iter().enumerate() {
            if let Some(allowed) = &solver.stroke_allowed[s] {
                if chain.iter().any(|&b| !allowed[b]) {
                    continue;
                }
            }
            let (line, cum) = &lines[c];
            for reversed in [false, true] {
                let mut cost = 0.0;
                for (i, y) in ys.iter().enumerate() {
                    let u = i as f64 / (SAMPLES - 1) as f64;
                    let x = at(line, cum, if reversed { 1.0 - u } else { u });
                    cost += (y - x).norm_squared();
                }
                list.push((cost / SAMPLES as f64, c, reversed));
            }
        }
        list.sort_by(|a, b| a.0.total_cmp(&b.0));
        candidates.push(list);
    }
    let stray2 = (solver.options.stray_distance * solver.height).powi(2);
    let mut used = vec![false; model.bones.len()];
    let mut result: Vec<Option<Vec<usize>>> = vec![None; strokes];
    let mut done = vec![false; strokes];
    loop {
        // The unassigned stroke whose best still-free chain fits best.
        let mut pick: Option<(f64, usize, usize, bool)> = None;
        for s in 0..strokes {
            if done[s] {
                continue;
            }
            let free = candidates[s]
                .iter()
                .find(|&&(_, c, _)| chains[c].iter().all(|&b| !used[b]));
            if let Some(&(cost, c, rev)) = free {
                if pick.is_none_or(|p| cost < p.0) {
                    pick = Some((cost, s, c, rev));
                }
            } else {
                done[s] = true;
            }
        }
        let Some((cost, s, c, reversed)) = pick else {
            break;
        };
        done[s] = true;
        if cost > stray2 {
            continue; // a stray: explained by no chain
        }
        for &b in &chains[c] {
            used[b] = true;
        }
        let mut bones = chains[c].clone();
        if reversed {
            bones.reverse();
        }
        result[s] = Some(bones);
    }
    result
}
