//! The mirror-image hypothesis. Strokes drawn on a body turned away from the viewer fit
//! its mirror image turned around almost as well: every left limb on the right limb's
//! stroke, the knees bent backwards. Local moves swap one pair of limbs at a time, and no
//! single swap explains the strokes better, so the best fit's whole assignment is mirrored
//! (left and right chains exchanged, by the joints' names) and fitted again from every
//! start; the rig's ranges and the bend preference in the score then choose.

use super::bones::BoneModel;
use super::chains::Assignment;
use super::local_moves::improve;
use super::solver::{ChainFit, Solver};
use crate::mirror::mirror_pairs;
use crate::skeleton::{Pose, Skeleton};

/// The mirror image is improved by local moves only when its chain step explains the
/// strokes within this factor of the best fit (as the hypotheses of the first search).
const MIRROR_CUTOFF: f64 = 2.0;

/// The mirror image turns the body around: it replaces the best fit only when it explains
/// the strokes themselves as well (within this factor), not on the preferences alone (a
/// limb bent less, a stroke moved to an undrawn limb).
const MIRROR_DATA_TOLERANCE: f64 = 1.05;

/// For each bone, the bone that mirrors it: from the mirror of its joint to the mirror of
/// its tip (a joint with no pair mirrors itself). `None` for a bone with no mirror bone, and
/// no map at all when no joint has a pair.
pub(super) fn bone_mirrors(skeleton: &Skeleton, model: &BoneModel) -> Option<Vec<Option<usize>>> {
    let pairs = mirror_pairs(skeleton);
    if pairs.is_empty() {
        return None;
    }
    let mut mirror: Vec<usize> = (0..skeleton.len()).collect();
    for (left, right) in pairs {
        mirror[left] = right;
        mirror[right] = left;
    }
    let bone_of: std::collections::HashMap<(usize, usize), usize> = model
        .bones
        .iter()
        .enumerate()
        .map(|(b, bone)| ((bone.joint, bone.child), b))
        .collect();
    Some(
        model
            .bones
            .iter()
            .map(|bone| {
                bone_of
                    .get(&(mirror[bone.joint], mirror[bone.child]))
                    .copied()
            })
            .collect(),
    )
}

/// `assignment` with every chain replaced by its mirror image (a chain with a bone that has
/// no mirror keeps its own); `None` when the image would cover a bone twice.
fn mirrored(
    assignment: &[Assignment],
    mirrors: &[Option<usize>],
    bones: usize,
) -> Option<Vec<Assignment>> {
    let mut taken = vec![false; bones];
    let mut image = Vec::with_capacity(assignment.len());
    for a in assignment {
        let a = a.as_ref().map(|(chain, reversed)| {
            let chain = chain
                .iter()
                .map(|&b| mirrors[b])
                .collect::<Option<Vec<usize>>>()
                .unwrap_or_else(|| chain.clone());
            (chain, *reversed)
        });
        for &b in a.iter().flat_map(|a| &a.0) {
            if std::mem::replace(&mut taken[b], true) {
                return None;
            }
        }
        image.push(a);
    }
    Some(image)
}

impl Solver<'_> {
    /// How well `fit`'s pose explains the strokes (the score without its preferences).
    fn data_score(&mut self, fit: &ChainFit) -> f64 {
        let saved = std::mem::replace(&mut self.fitter.pose, fit.pose.clone());
        let (data, _) = self.score_parts(&fit.assignment, &fit.layout);
        self.fitter.pose = saved;
        data
    }

    /// `best`, or its mirror image fitted from each of `starts` and improved, whichever
    /// explains the strokes better.
    pub(super) fn try_mirror_image(&mut self, best: ChainFit, starts: &[Pose]) -> ChainFit {
        let Some(mirrors) = &self.bone_mirrors else {
            return best;
        };
        let bones = self.setup.model.bones.len();
        let Some(seed) = mirrored(&best.assignment, mirrors, bones) else {
            return best;
        };
        if seed == best.assignment {
            return best;
        }
        let mut seeded: Option<ChainFit> = None;
        for start in starts {
            if self.setup.interrupt.is_set() {
                break;
            }
            self.fitter.pose = start.clone();
            self.by_shape = best.by_shape;
            let fit = self.chain_step(Some(seed.clone()));
            if seeded.as_ref().is_none_or(|s| fit.score < s.score) {
                seeded = Some(fit);
            }
        }
        match seeded {
            Some(fit) if fit.score <= MIRROR_CUTOFF * best.score => {
                let fit = improve(self, fit);
                let explained =
                    self.data_score(&fit) <= MIRROR_DATA_TOLERANCE * self.data_score(&best);
                if fit.score < best.score && explained {
                    fit
                } else {
                    best
                }
            }
            _ => best,
        }
    }
}
