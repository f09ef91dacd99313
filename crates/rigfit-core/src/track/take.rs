//! A whole take: the first frame started from the rig's stored pose or found by the
//! first-frame search ([`initialise_with`]), then frame after frame from the last pose, and a
//! frame whose fit collapses (its inliers far below the frames before it) searched for again
//! instead of dragging its error into every later frame.
//!
//! Fits are compared by one score: the data's summed inlier posteriors of one E-step (eq. 17,
//! the uniform outlier class) at a common `sigma`, per data point.

use super::{
    ArticulatedModel, FrameFit, InitialiseOptions, TrackError, TrackOptions, Tracker,
    initialise_with,
};
use crate::math::Point3;
use crate::skeleton::Pose;

/// Where a take's first frame starts.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum StartMode {
    /// From the stored pose, unless its fit explains the data poorly and the search's
    /// explains it clearly better.
    Auto,
    /// From the stored pose (the rig file's pose), whatever it explains.
    Stored,
    /// From the search, whatever the stored pose would explain.
    Search,
}

/// A take's settings beyond the tracker's own.
#[derive(Clone, Debug, PartialEq)]
pub struct TakeOptions {
    pub start: StartMode,
    /// The first-frame search's settings (also the recovery's).
    pub search: InitialiseOptions,
    /// [`StartMode::Auto`]: a stored pose whose fit explains at least this share of the
    /// first frame's points is kept without searching.
    pub good_share: f64,
    /// The search's pose replaces a fit only when it explains this much more of the data
    /// (share of the points): a search that merely ties keeps what tracking found.
    pub search_margin: f64,
    /// Search again on a frame whose fit collapsed.
    pub recover: bool,
    /// A frame has collapsed when its share of inliers (of its points) falls below this
    /// share of the median over the last `recent_frames` frames.
    pub collapse_share: f64,
    pub recent_frames: usize,
}

impl Default for TakeOptions {
    fn default() -> Self {
        Self {
            start: StartMode::Auto,
            search: InitialiseOptions::default(),
            good_share: 0.6,
            search_margin: 0.02,
            recover: true,
            collapse_share: 0.6,
            recent_frames: 5,
        }
    }
}

/// How a frame's fit was found.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum FrameStart {
    /// Tracked on from the previous frame.
    Tracked,
    /// The first frame, from the stored pose. `searched`: the search's score when it ran
    /// and lost.
    Stored { score: f64, searched: Option<f64> },
    /// The first frame, from the search's pose. `stored`: the stored pose's score when it
    /// was tried.
    Searched { score: f64, stored: Option<f64> },
    /// A collapsed frame (`inliers` against the `expected` count: the recent frames'
    /// median share of inliers times this frame's points) searched for again: `recovered` when the search's pose won (its score against the tracked one's).
    Collapsed {
        inliers: usize,
        expected: f64,
        tracked_score: f64,
        search_score: f64,
        recovered: bool,
    },
}

/// One frame of a take.
#[derive(Clone, Debug)]
pub struct TakeFrame {
    pub fit: FrameFit,
    pub start: FrameStart,
}

/// Tracks a take: [`Tracker`] with the first frame's start chosen and collapsed frames
/// searched for again (see the module's documentation).
#[derive(Debug)]
pub struct Take {
    tracker: Tracker,
    options: TakeOptions,
    /// The share of inliers of the frames tracked so far (the last `recent_frames`).
    recent_shares: Vec<f64>,
    frames: usize,
}

impl Take {
    /// A take of `model` (starting from its stored pose) tracked with `track_options`.
    pub fn new(
        model: ArticulatedModel,
        track_options: TrackOptions,
        options: TakeOptions,
    ) -> Result<Self, TrackError> {
        Ok(Self {
            tracker: Tracker::new(model, track_options)?,
            options,
            recent_shares: Vec::new(),
            frames: 0,
        })
    }

    /// The tracker (its model and current pose).
    pub fn tracker(&self) -> &Tracker {
        &self.tracker
    }

    /// Tracks the next frame.
    pub fn track(&mut self, data: &[Point3]) -> Result<TakeFrame, TrackError> {
        let frame = if self.frames == 0 {
            self.first_frame(data)?
        } else {
            self.next_frame(data)?
        };
        self.frames += 1;
        self.recent_shares
            .push(frame.fit.inliers as f64 / data.len() as f64);
        let keep = self.options.recent_frames.max(1);
        if self.recent_shares.len() > keep {
            self.recent_shares.remove(0);
        }
        Ok(frame)
    }

    /// The first frame: the stored pose, the search, or (auto) the stored pose unless the
    /// search explains the data clearly better.
    fn first_frame(&mut self, data: &[Point3]) -> Result<TakeFrame, TrackError> {
        let stored = self.tracker.pose().clone();
        if self.options.start == StartMode::Search {
            let found = self.search(&stored, data)?;
            self.tracker.set_pose(&found.0);
            let fit = self.tracker.track(data)?;
            return Ok(TakeFrame {
                fit,
                start: FrameStart::Searched {
                    score: found.1,
                    stored: None,
                },
            });
        }
        let fit = self.tracker.track(data)?;
        let stored_score = self.score(data);
        if self.options.start == StartMode::Stored || stored_score >= self.options.good_share {
            return Ok(TakeFrame {
                fit,
                start: FrameStart::Stored {
                    score: stored_score,
                    searched: None,
                },
            });
        }
        let (pose, search_score) = self.search(&stored, data)?;
        if search_score > stored_score + self.options.search_margin {
            self.tracker.set_pose(&pose);
            let fit = self.tracker.track(data)?;
            Ok(TakeFrame {
                fit,
                start: FrameStart::Searched {
                    score: search_score,
                    stored: Some(stored_score),
                },
            })
        } else {
            Ok(TakeFrame {
                fit,
                start: FrameStart::Stored {
                    score: stored_score,
                    searched: Some(search_score),
                },
            })
        }
    }

    /// A frame after the first: tracked on, and searched for again when it collapsed.
    fn next_frame(&mut self, data: &[Point3]) -> Result<TakeFrame, TrackError> {
        let before = self.tracker.pose().clone();
        let fit = self.tracker.track(data)?;
        let expected = median(&self.recent_shares) * data.len() as f64;
        let collapsed = self.options.recover
            && self.recent_shares.len() >= 2
            && (fit.inliers as f64) < self.options.collapse_share * expected;
        if !collapsed {
            return Ok(TakeFrame {
                fit,
                start: FrameStart::Tracked,
            });
        }
        let tracked_score = self.score(data);
        let (pose, search_score) = self.search(&before, data)?;
        let recovered = search_score > tracked_score + self.options.search_margin;
        tracing::debug!(
            "frame {}: {} inliers against {expected:.0}; search {search_score:.3} vs tracked \
             {tracked_score:.3}",
            self.frames,
            fit.inliers
        );
        let start = FrameStart::Collapsed {
            inliers: fit.inliers,
            expected,
            tracked_score,
            search_score,
            recovered,
        };
        if !recovered {
            // The search lost: tracking goes on from what it found.
            return Ok(TakeFrame { fit, start });
        }
        self.tracker.set_pose(&pose);
        let fit = self.tracker.track(data)?;
        Ok(TakeFrame { fit, start })
    }

    /// The search from `start` (the model's limbs as they are there): its pose and score.
    fn search(&self, start: &Pose, data: &[Point3]) -> Result<(Pose, f64), TrackError> {
        let mut model = self.tracker.model.clone();
        model.start.clone_from(start);
        let found = initialise_with(&model, &self.tracker.options, &self.options.search, data)?;
        Ok((found.pose, found.score))
    }

    /// The score of the tracker's current pose on `data` (the search's own measure).
    fn score(&mut self, data: &[Point3]) -> f64 {
        let sigma = self.options.search.score_sigma * self.tracker.model.height;
        self.tracker.explained_share(data, sigma)
    }
}

/// The median of `values` (0 when there are none).
fn median(values: &[f64]) -> f64 {
    if values.is_empty() {
        return 0.0;
    }
    let mut sorted = values.to_vec();
    sorted.sort_by(f64::total_cmp);
    let mid = sorted.len() / 2;
    if sorted.len() % 2 == 1 {
        sorted[mid]
    } else {
        0.5 * (sorted[mid - 1] + sorted[mid])
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::humanoid::humanoid;
    use crate::math::{Quat, Vector3};

    /// The humanoid's model, and its own surface points moved rigidly by `turn` and `shift`
    /// (fractions of the height) with the pose they show.
    fn model_and_moved(turn: f64, shift: Vector3) -> (ArticulatedModel, Vec<Point3>, Pose) {
        let model = ArticulatedModel::from_rig(&humanoid(), 1500).expect("model");
        let h = model.height;
        let tracker = Tracker::new(model.clone(), TrackOptions::default()).expect("tracker");
        let turn = Quat::from_axis_angle(&Vector3::y_axis(), turn);
        let shift = shift * h;
        let data = tracker
            .texture_positions()
            .iter()
            .map(|p| Point3::from(turn * p.coords + shift))
            .collect();
        let truth = model.skeleton.moved_rigidly(&model.start, &turn, &shift);
        (model, data, truth)
    }

    /// Mean joint distance between two poses, as a fraction of the height.
    fn error(model: &ArticulatedModel, a: &Pose, b: &Pose) -> f64 {
        let (a, b) = (
            model.skeleton.joint_positions(a),
            model.skeleton.joint_positions(b),
        );
        a.iter().zip(&b).map(|(p, q)| (p - q).norm()).sum::<f64>() / a.len() as f64 / model.height
    }

    #[test]
    fn a_stored_pose_that_explains_the_first_frame_is_kept_without_searching() {
        let (model, data, truth) = model_and_moved(0.0, Vector3::zeros());
        let mut take = Take::new(
            model.clone(),
            TrackOptions::default(),
            TakeOptions::default(),
        )
        .expect("take");
        let frame = take.track(&data).expect("frame tracks");
        assert!(
            matches!(frame.start, FrameStart::Stored { searched: None, score } if score > 0.6),
            "{:?}",
            frame.start
        );
        assert!(error(&model, &frame.fit.pose, &truth) < 0.01);
    }

    #[test]
    fn a_first_frame_far_from_the_stored_pose_is_found_by_the_search() {
        let (model, data, truth) = model_and_moved(2.3, Vector3::new(1.1, 0.0, -0.8));
        for start in [StartMode::Auto, StartMode::Search] {
            let options = TakeOptions {
                start,
                ..TakeOptions::default()
            };
            let mut take =
                Take::new(model.clone(), TrackOptions::default(), options).expect("take");
            let frame = take.track(&data).expect("frame tracks");
            assert!(
                matches!(frame.start, FrameStart::Searched { .. }),
                "{start:?}: {:?}",
                frame.start
            );
            let e = error(&model, &frame.fit.pose, &truth);
            assert!(e < 0.02, "{start:?}: mean joint error {:.2}%", 100.0 * e);
        }
        // `--init stored` keeps the stored pose, however far it is.
        let options = TakeOptions {
            start: StartMode::Stored,
            ..TakeOptions::default()
        };
        let mut take = Take::new(model.clone(), TrackOptions::default(), options).expect("take");
        let frame = take.track(&data).expect("frame tracks");
        assert!(matches!(frame.start, FrameStart::Stored { .. }));
        assert!(error(&model, &frame.fit.pose, &truth) > 0.2);
    }

    #[test]
    fn a_frame_that_collapses_is_searched_for_again() {
        let (model, still, _) = model_and_moved(0.0, Vector3::zeros());
        let (_, jumped, truth) = model_and_moved(1.9, Vector3::new(-1.2, 0.0, 0.9));
        let mut errors = Vec::new();
        for recover in [true, false] {
            let options = TakeOptions {
                recover,
                ..TakeOptions::default()
            };
            let mut take =
                Take::new(model.clone(), TrackOptions::default(), options).expect("take");
            for _ in 0..4 {
                let frame = take.track(&still).expect("frame tracks");
                assert!(!matches!(frame.start, FrameStart::Collapsed { .. }));
            }
            let frame = take.track(&jumped).expect("frame tracks");
            if recover {
                assert!(
                    matches!(
                        frame.start,
                        FrameStart::Collapsed {
                            recovered: true,
                            ..
                        }
                    ),
                    "{:?}",
                    frame.start
                );
            }
            errors.push(error(&model, &frame.fit.pose, &truth));
        }
        assert!(errors[0] < 0.02, "recovered: {:.2}%", 100.0 * errors[0]);
        assert!(errors[1] > 0.2, "not recovered: {:.2}%", 100.0 * errors[1]);
    }
}
