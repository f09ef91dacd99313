//! The mirror-image hypothesis. Strokes drawn on a body turned away from the viewer fit
//! its mirror image turned around almost as well: every left limb on the right limb's
//! stroke, the knees bent backwards. Local moves swap one pair of limbs at a time, and no
//! single swap explains the strokes better, so the best fit's whole assignment is mirrored
//! (left and right chains exchanged, by the joints' names) and fitted again from every
//! start; the rig's ranges and the bend preference in the score then choose.

use super::bones::BoneModel;
use super::chains::{Assignment, covers_a_bone_twice};
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

/// The mirror image of `chain`, bone by bone (`mirrors`: one entry per bone, [`bone_mirrors`]);
/// `None` when a bone has no mirror.
pub(super) fn chain_image(chain: &[usize], mirrors: &[Option<usize>]) -> Option<Vec<usize>> {
    chain.iter().map(|&b| mirrors[b]).collect()
}

/// `assignment` with every stroke whose chain lies on the bones `below` moved to its mirror
/// image (`mirrors`: one entry per bone, [`bone_mirrors`]); a chain with a bone that has no
/// mirror, or whose image its stroke may not cover (`may_cover(stroke, chain)`: a stroke
/// pinned to bones), keeps its own. `None` when no stroke moves or the image would cover a
/// bone twice.
pub(super) fn mirrored(
    assignment: &[Assignment],
    below: &[bool],
    mirrors: &[Option<usize>],
    may_cover: impl Fn(usize, &[usize]) -> bool,
) -> Option<Vec<Assignment>> {
    let mut turned = assignment.to_vec();
    let mut moved = false;
    for (u, a) in turned.iter_mut().enumerate() {
        let Some((chain, reversed)) = a.as_ref() else {
            continue;
        };
        if !chain.iter().all(|&b| below[b]) {
            continue;
        }
        let Some(image) = chain_image(chain, mirrors) else {
            continue;
        };
        if image != *chain && may_cover(u, &image) {
            *a = Some((image, *reversed));
            moved = true;
        }
    }
    (moved && !covers_a_bone_twice(&turned, mirrors.len())).then_some(turned)
}

impl Solver<'_> {
    /// How well `fit`'s pose explains the strokes (the score without its preferences).
    fn data_score(&self, fit: &ChainFit) -> f64 {
        self.score_parts(&fit.pose, &fit.assignment, &fit.layout).0
    }

    /// `best`, or its mirror image fitted from each of `starts` and improved, whichever
    /// explains the strokes better.
    pub(super) fn try_mirror_image(&mut self, best: ChainFit, starts: &[Pose]) -> ChainFit {
        let Some(mirrors) = &self.bone_mirrors else {
            return best;
        };
        let may_cover = |s: usize, chain: &[usize]| self.setup.stroke_may_cover(s, chain);
        let everywhere = vec![true; mirrors.len()];
        let Some(seed) = mirrored(&best.assignment, &everywhere, mirrors, may_cover) else {
            return best;
        };
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

#[cfg(test)]
mod tests {
    use super::*;
    use crate::skeleton::Joint;
    use crate::{Trs, Vector3};

    /// A hub with a two-bone arm on each side, named left and right.
    fn two_arms() -> (Skeleton, BoneModel) {
        let at = |x: f64| Trs::from_translation(Vector3::new(x, 0.0, 0.0));
        let joints = vec![
            Joint::new("hub", None, Trs::default()),
            Joint::new("upper_left", Some(0), at(0.1)),
            Joint::new("lower_left", Some(1), at(0.5)),
            Joint::new("hand_left", Some(2), at(0.5)),
            Joint::new("upper_right", Some(0), at(-0.1)),
            Joint::new("lower_right", Some(4), at(-0.5)),
            Joint::new("hand_right", Some(5), at(-0.5)),
        ];
        let skeleton = Skeleton::new(joints).expect("valid");
        let model = BoneModel::new(&skeleton, &skeleton.rest_pose(), 0.05, 1e-6);
        (skeleton, model)
    }

    fn bone(model: &BoneModel, joint: usize) -> usize {
        model
            .bones
            .iter()
            .position(|b| b.joint == joint)
            .expect("a bone")
    }

    #[test]
    fn left_chains_map_to_right_ones_and_pins_keep_theirs() {
        let (skeleton, model) = two_arms();
        let mirrors = bone_mirrors(&skeleton, &model).expect("named pairs");
        let left = vec![bone(&model, 1), bone(&model, 2)];
        let right = vec![bone(&model, 4), bone(&model, 5)];
        let assignment = vec![Some((left.clone(), false)), None];
        let any = |_: usize, _: &[usize]| true;
        let everywhere = vec![true; mirrors.len()];
        let image = mirrored(&assignment, &everywhere, &mirrors, any).expect("an image");
        assert_eq!(image, vec![Some((right.clone(), false)), None]);
        // Both arms drawn: they trade places.
        let both = vec![Some((left.clone(), false)), Some((right.clone(), true))];
        let image = mirrored(&both, &everywhere, &mirrors, any).expect("an image");
        assert_eq!(
            image,
            vec![Some((right.clone(), false)), Some((left.clone(), true))]
        );
        // A stroke pinned to the left arm keeps it, and then the other stroke's image would
        // cover the left arm twice: no image.
        let pinned = |s: usize, chain: &[usize]| s != 0 || chain == left.as_slice();
        assert_eq!(mirrored(&both, &everywhere, &mirrors, pinned), None);
    }

    #[test]
    fn a_skeleton_without_named_sides_has_no_mirror() {
        let at = |x: f64| Trs::from_translation(Vector3::new(x, 0.0, 0.0));
        let joints = vec![
            Joint::new("root", None, Trs::default()),
            Joint::new("a", Some(0), at(1.0)),
            Joint::new("b", Some(1), at(1.0)),
        ];
        let skeleton = Skeleton::new(joints).expect("valid");
        let model = BoneModel::new(&skeleton, &skeleton.rest_pose(), 0.05, 1e-6);
        assert!(bone_mirrors(&skeleton, &model).is_none());
    }
}
