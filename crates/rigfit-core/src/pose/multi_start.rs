//! The rigid multi-start: before any limb moves, the whole character is placed on the
//! strokes by annealed softassign over its root alone, from four headings about the
//! vertical; and the character where it stands is turned about its root to more headings,
//! unfitted. Each placement and turn is a hypothesis the chain step then fits.

use super::annealing::{anneal, schedule};
use super::fitting::Fitter;
use super::setup::Setup;
use crate::geometry::centroid;
use crate::kinematics::{DofLayout, ForwardKinematics};
use crate::math::{Matrix4, Quat, Trs, Vector3};
use crate::skeleton::Pose;
use rayon::prelude::*;

/// Headings tried about each candidate vertical axis.
const HEADINGS: usize = 4;

/// Placements kept as hypotheses (the best explained).
const KEPT_PLACEMENTS: usize = 4;

/// The starts of the chain step, besides the character where it stands, when the whole
/// character may move: the rigid placements, then the character turned where it stands
/// ([`turned_starts`]). Both are judged on a thinned setup: every third stroke sample, every
/// other model point (a rigid fit needs few points).
pub(super) fn placements_and_turns(setup: &Setup, root: usize) -> (Vec<Pose>, Vec<Pose>) {
    let thin = setup.thinned(3, 2);
    (rigid_placements(&thin, root), turned_starts(&thin, root))
}

/// The rigid placements alone (the paper's method starts from the best one), judged on the
/// same thinned setup as in [`placements_and_turns`].
pub(super) fn placements(setup: &Setup, root: usize) -> Vec<Pose> {
    rigid_placements(&setup.thinned(3, 2), root)
}

/// Rigid alignments of the whole character from [`HEADINGS`] headings about y and about z
/// (files are y-up or z-up, and strokes do not say which), the [`KEPT_PLACEMENTS`] best
/// explained first; `thin` is the solve's thinned setup.
fn rigid_placements(thin: &Setup, root: usize) -> Vec<Pose> {
    let skeleton = thin.skeleton;
    let mut only_root = vec![false; skeleton.len()];
    only_root[root] = true;
    let layout = DofLayout::with_active(skeleton, &only_root);
    let data_centre = centroid(&thin.strokes.points).coords;
    let sigmas = schedule(thin.height, 0.3, 0.05, 6, false);
    let start_fk = ForwardKinematics::new(skeleton, thin.start);
    let model_centre = centroid(&thin.model.world_points(&start_fk)).coords;
    let parent = skeleton
        .joint(root)
        .parent
        .map(|p| *start_fk.world(p))
        .unwrap_or_else(Matrix4::identity);
    let parent_inverse = parent.try_inverse().unwrap_or_else(Matrix4::identity);
    let turns: Vec<Quat> = (0..HEADINGS)
        .flat_map(|heading| {
            let angle = heading as f64 * std::f64::consts::TAU / HEADINGS as f64;
            let about_y = Quat::from_axis_angle(&Vector3::y_axis(), angle);
            let about_z = Quat::from_axis_angle(&Vector3::z_axis(), angle);
            // Heading 0 is the same turn about either axis.
            std::iter::once(about_y).chain((heading > 0).then_some(about_z))
        })
        .collect();
    // Each heading is fitted on its own: in parallel, with the same results.
    let mut found: Vec<(f64, Pose)> = turns
        .par_iter()
        .map(|&turn| {
            // Turn about the vertical through the model's centre, then move onto the strokes.
            let turn = Trs::new(Vector3::zeros(), turn).to_matrix();
            let world_root = Matrix4::new_translation(&(data_centre - model_centre))
                * Matrix4::new_translation(&model_centre)
                * turn
                * Matrix4::new_translation(&-model_centre)
                * start_fk.world(root);
            let trs = Trs::from_matrix(&(parent_inverse * world_root));
            let mut pose = thin.start.clone();
            pose.local[root].translation = trs.translation;
            pose.local[root].rotation = trs.rotation;
            let mut fitter = Fitter::new(pose, thin.options.prior_weight);
            anneal(thin, &mut fitter, &layout, &sigmas, None);
            (truncated_chamfer(thin, &fitter.pose), fitter.pose)
        })
        .collect();
    found.sort_by(|a, b| a.0.total_cmp(&b.0));
    found
        .into_iter()
        .take(KEPT_PLACEMENTS)
        .map(|f| f.1)
        .collect()
}

/// Mean over stroke samples of the squared distance to the nearest model point, capped at
/// three outlier distances: how well `pose` explains the strokes.
fn truncated_chamfer(setup: &Setup, pose: &Pose) -> f64 {
    let fk = ForwardKinematics::new(setup.skeleton, pose);
    let world = setup.model.world_points(&fk);
    let cap = (setup.options.outlier_distance * setup.height * 3.0).powi(2);
    let data = &setup.strokes.points;
    data.iter()
        .map(|y| {
            world
                .iter()
                .map(|v| (y - v).norm_squared())
                .fold(cap, f64::min)
        })
        .sum::<f64>()
        / data.len().max(1) as f64
}

/// Headings about y and about z at which the character where it stands is turned
/// ([`turned_starts`]), the start among them.
const TURNED_HEADINGS: usize = 8;

/// Turned characters kept as hypotheses (measured on the tuning half: 6 against 2 and 4,
/// and against every one of the 14, which gained a little more at twice the time).
const TURNED_STARTS: usize = 6;

/// The character where it stands turned about its root by [`TURNED_HEADINGS`] even steps
/// about y and about z (the start itself left out), the [`TURNED_STARTS`] that explain the
/// strokes best, unfitted. A body turned far (facing away) with its limbs far from their
/// strokes is reached from these when the rigid placements, pulled by the limbs, settle at
/// another heading. `thin` is the solve's thinned setup.
fn turned_starts(thin: &Setup, root: usize) -> Vec<Pose> {
    let skeleton = thin.skeleton;
    let world = skeleton.world_rotations(thin.start);
    let mut found: Vec<(f64, Pose)> = (1..TURNED_HEADINGS)
        .flat_map(|heading| {
            let angle = heading as f64 * std::f64::consts::TAU / TURNED_HEADINGS as f64;
            [Vector3::y_axis(), Vector3::z_axis()].map(|axis| Quat::from_axis_angle(&axis, angle))
        })
        .map(|turn| {
            let mut pose = thin.start.clone();
            pose.local[root].rotation = skeleton.turned_in_world(&pose, &world, root, &turn);
            (truncated_chamfer(thin, &pose), pose)
        })
        .collect();
    found.sort_by(|a, b| a.0.total_cmp(&b.0));
    found.into_iter().take(TURNED_STARTS).map(|f| f.1).collect()
}
