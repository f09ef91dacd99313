//! The rigid multi-start: before any limb moves, the whole character is placed on the
//! strokes by annealed softassign over its root alone, from four headings about the
//! vertical. Each placement is a hypothesis the chain step then fits.

use super::annealing::{anneal, schedule};
use super::fitting::Fitter;
use super::setup::Setup;
use crate::geometry::centroid;
use crate::kinematics::{DofLayout, ForwardKinematics};
use crate::math::{Matrix4, Quat, Trs, Vector3};
use crate::skeleton::Pose;

/// Headings tried about each candidate vertical axis.
const HEADINGS: usize = 4;

/// Placements kept as hypotheses (the best explained).
const KEPT_PLACEMENTS: usize = 4;

/// Rigid alignments of the whole character from [`HEADINGS`] headings about y and about z
/// (files are y-up or z-up, and strokes do not say which), the [`KEPT_PLACEMENTS`] best
/// explained first.
pub(super) fn rigid_placements(setup: &Setup, root: usize) -> Vec<Pose> {
    let skeleton = setup.skeleton;
    let mut only_root = vec![false; skeleton.len()];
    only_root[root] = true;
    let layout = DofLayout::with_active(skeleton, &only_root);
    // A rigid fit needs few points: every third stroke sample, every other model point.
    let thin = setup.thinned(3, 2);
    let data_centre = centroid(&thin.strokes.points).coords;
    let sigmas = schedule(setup.height, 0.3, 0.05, 6, false);
    let start_fk = ForwardKinematics::new(skeleton, setup.start);
    let model_centre = centroid(&thin.model.world_points(&start_fk)).coords;
    let parent = skeleton
        .joint(root)
        .parent
        .map(|p| *start_fk.world(p))
        .unwrap_or_else(Matrix4::identity);
    let parent_inverse = parent.try_inverse().unwrap_or_else(Matrix4::identity);
    let turns = (0..HEADINGS).flat_map(|heading| {
        let angle = heading as f64 * std::f64::consts::TAU / HEADINGS as f64;
        let about_y = Quat::from_axis_angle(&Vector3::y_axis(), angle);
        let about_z = Quat::from_axis_angle(&Vector3::z_axis(), angle);
        // Heading 0 is the same turn about either axis.
        std::iter::once(about_y).chain((heading > 0).then_some(about_z))
    });
    let mut found: Vec<(f64, Pose)> = turns
        .map(|turn| {
            // Turn about the vertical through the model's centre, then move onto the strokes.
            let turn = Trs::new(Vector3::zeros(), turn).to_matrix();
            let world_root = Matrix4::new_translation(&(data_centre - model_centre))
                * Matrix4::new_translation(&model_centre)
                * turn
                * Matrix4::new_translation(&-model_centre)
                * start_fk.world(root);
            let trs = Trs::from_matrix(&(parent_inverse * world_root));
            let mut pose = setup.start.clone();
            pose.local[root].translation = trs.translation;
            pose.local[root].rotation = trs.rotation;
            let mut fitter = Fitter::new(pose, setup.options.prior_weight);
            anneal(&thin, &mut fitter, &layout, &sigmas, None);
            (truncated_chamfer(&thin, &fitter.pose), fitter.pose)
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
