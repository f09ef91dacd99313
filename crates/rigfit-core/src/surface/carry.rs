//! Patches short of data keep to their neighbours (rigfit's addition to Cagniart et al.
//! 2010): after a frame's fit, a patch that the points explained less than its share
//! ([`patch_support`](super::solve::patch_support)) is moved toward where its best-seen
//! linked patch (a neighbour of its piece, or the other side of a contact link) carries it,
//! keeping their relative placement of the last frame, in proportion to what it lacks. The
//! patches are settled from the best seen outward along the links, so a chain of unseen
//! patches (a finger out of view) is carried link by link from the piece it hangs from,
//! instead of staying where it was lost or following clutter.

use std::cmp::Ordering;
use std::collections::BinaryHeap;

use super::model::{PatchModel, PatchPose};
use crate::math::rotation_toward;

/// A patch waiting to be settled, by its support (best first).
#[derive(Clone, Copy, PartialEq)]
struct Waiting {
    support: f64,
    patch: usize,
}

impl Eq for Waiting {}

impl Ord for Waiting {
    fn cmp(&self, other: &Self) -> Ordering {
        self.support
            .total_cmp(&other.support)
            .then(other.patch.cmp(&self.patch))
    }
}

impl PartialOrd for Waiting {
    fn partial_cmp(&self, other: &Self) -> Option<Ordering> {
        Some(self.cmp(other))
    }
}

/// Moves the patches of `pose` short of data (`support` below 1) toward where their
/// best-seen settled partner carries them from `last` (see the module's comment).
pub fn carry_unseen(model: &PatchModel, last: &PatchPose, pose: &mut PatchPose, support: &[f64]) {
    let n = model.patch_count();
    if support.len() != n || support.iter().all(|&s| s >= 1.0) {
        return;
    }
    let mut partners: Vec<Vec<usize>> = model
        .neighbours
        .iter()
        .map(|ns| ns.iter().map(|&l| l as usize).collect())
        .collect();
    for link in &model.contacts {
        partners[link.k as usize].push(link.l as usize);
        partners[link.l as usize].push(link.k as usize);
    }
    let mut settled = vec![false; n];
    let mut queue = BinaryHeap::new();
    let settle = |k: usize, settled: &mut Vec<bool>, queue: &mut BinaryHeap<Waiting>| {
        settled[k] = true;
        for &l in &partners[k] {
            if !settled[l] {
                queue.push(Waiting {
                    support: support[l],
                    patch: l,
                });
            }
        }
    };
    for k in 0..n {
        if support[k] >= 1.0 {
            settle(k, &mut settled, &mut queue);
        }
    }
    loop {
        let Some(Waiting { patch: k, .. }) = queue.pop() else {
            // A piece with no patch fully seen: its best-seen patch anchors it.
            let best = (0..n)
                .filter(|&k| !settled[k])
                .max_by(|&a, &b| support[a].total_cmp(&support[b]));
            match best {
                Some(k) => {
                    settle(k, &mut settled, &mut queue);
                    continue;
                }
                None => break,
            }
        };
        if settled[k] {
            continue;
        }
        // The settled partner seen best carries it.
        let carrier = partners[k]
            .iter()
            .copied()
            .filter(|&l| settled[l])
            .max_by(|&a, &b| support[a].total_cmp(&support[b]));
        if let Some(l) = carrier {
            let lack = (1.0 - support[k]).clamp(0.0, 1.0);
            // The carrier's motion since the last frame, applied to k's last placement.
            let turn = pose.rotation[l] * last.rotation[l].transpose();
            let carried_rotation = turn * last.rotation[k];
            let carried_centre = pose.centre[l] + turn * (last.centre[k] - last.centre[l]);
            pose.rotation[k] = rotation_toward(&pose.rotation[k], &carried_rotation, lack);
            let centre = pose.centre[k];
            pose.centre[k] = centre + (carried_centre - centre) * lack;
        }
        settle(k, &mut settled, &mut queue);
    }
}
