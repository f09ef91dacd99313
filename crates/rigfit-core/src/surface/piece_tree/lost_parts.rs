//! Fitting a frame again when the pieces' tree loses a part (rigfit's addition, issue 22).
//! The articulated tracker follows the tree from the last frame's motion continued, with a
//! kernel a few percent of the height wide: a limb that turns or stops sharply between two
//! scans (a robot arm reversing, moving a third of the diagonal in a frame) is left behind
//! on the wrong data, and the patches' narrower kernel cannot bring it back. Such a frame
//! shows in the share of each piece that lies on data: averaged over the pieces (so a small
//! part lost counts as much as a large one), it falls well below the last frame's. The frame
//! is then fitted again from three other starts, in parallel: without the motion continued,
//! with all of it continued, and with a wider first kernel; the fit that lays the pieces on
//! the most data is kept.

use rayon::prelude::*;

use super::PieceTree;
use crate::engine::PointGrid;
use crate::math::Point3;
use crate::track::{FrameFit, TrackOptions, Tracker, TrackerStart};

/// A piece counts in the coverage when at least this many texture points lie on it.
const MIN_PIECE_TEXTURE: usize = 10;
/// The other starts: the share of the last motion continued (`None`: the tree's own), and
/// the factor on the first kernel's width (the largest motion expected between frames).
const OTHER_STARTS: [(Option<f64>, f64); 3] = [(Some(0.0), 1.0), (Some(1.0), 1.0), (None, 3.0)];

impl PieceTree {
    /// Tracks the tree to `points` from its last motion continued; when the fit's coverage
    /// ([`coverage`]) falls below [`super::PieceTreeOptions::refit_below`] times the last
    /// frame's, also from [`OTHER_STARTS`], keeping the fit with the most coverage.
    pub(super) fn track_refitting_lost_parts(&mut self, points: &[Point3]) -> Option<FrameFit> {
        let start = self.tracker.frame_start();
        let fit = self.tracker.track(points).ok();
        let radius = self.choice_sigma * self.tracker.model().height;
        // The frame's points, found near the pieces by every fit judged.
        let grid = PointGrid::new(points, radius);
        let mut best = match fit {
            Some(_) => coverage(&self.tracker, &grid, radius),
            None => f64::NEG_INFINITY,
        };
        let mut fit = fit;
        if let (Some(ratio), Some(last)) = (self.refit_below, self.last_coverage)
            && best < ratio * last
        {
            let own = self.tracker.options.clone();
            let (tracker, grid) = (&self.tracker, &grid);
            let tried: Vec<(Tracker, Option<FrameFit>, f64)> = OTHER_STARTS
                .par_iter()
                .map(|&(prediction, widen)| {
                    refit(
                        tracker,
                        &start,
                        &own,
                        (prediction, widen),
                        points,
                        grid,
                        radius,
                    )
                })
                .collect();
            // The first start's fit stands unless another covers strictly more.
            for (tracker, other_fit, covered) in tried {
                if covered > best {
                    best = covered;
                    self.tracker = tracker;
                    fit = other_fit;
                }
            }
        }
        self.last_coverage = fit.as_ref().map(|_| best);
        fit
    }
}

/// `tracker` tracked to `points` again from `start`, continuing `prediction` of the last
/// motion (`None`: as `own` does) with its first kernel `widen` times as wide; with its
/// fit and coverage of `grid` (over `points`), and its options put back to `own`.
fn refit(
    tracker: &Tracker,
    start: &TrackerStart,
    own: &TrackOptions,
    (prediction, widen): (Option<f64>, f64),
    points: &[Point3],
    grid: &PointGrid,
    radius: f64,
) -> (Tracker, Option<FrameFit>, f64) {
    let mut other = tracker.clone();
    other.restart_from(start);
    other.options.prediction = prediction.unwrap_or(own.prediction);
    other.options.max_motion = own.max_motion * widen;
    let fit = other.track(points).ok();
    let covered = match fit {
        Some(_) => coverage(&other, grid, radius),
        None => f64::NEG_INFINITY,
    };
    other.options = own.clone();
    (other, fit, covered)
}

/// How much of the pieces lies on the data: per joint of the tree with at least
/// [`MIN_PIECE_TEXTURE`] texture points, the share of them with a point of `grid` within
/// `radius`, averaged over those joints (a small part counts as much as a large one).
fn coverage(tracker: &Tracker, grid: &PointGrid, radius: f64) -> f64 {
    let joints = tracker.model().skeleton.len();
    let (mut covered, mut all) = (vec![0usize; joints], vec![0usize; joints]);
    for (at, joint) in tracker
        .texture_positions()
        .iter()
        .zip(tracker.texture_joints())
    {
        all[joint] += 1;
        covered[joint] += usize::from(grid.any_within(at, radius));
    }
    let shares: Vec<f64> = (0..joints)
        .filter(|&j| all[j] >= MIN_PIECE_TEXTURE)
        .map(|j| covered[j] as f64 / all[j] as f64)
        .collect();
    shares.iter().sum::<f64>() / shares.len().max(1) as f64
}
