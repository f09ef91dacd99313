//! The fitting loop every model runs: the kernel width `sigma` annealed from wide to narrow,
//! and at each width an E-step (soft correspondences with an outlier class) followed by an
//! M-step (one update of the model's parameters), until the model stops moving at the final
//! width. Between frames of a sequence, the next frame starts from the last motion continued
//! ([`continued_trs`], [`continued_rotation`]).
//!
//! A model implements [`EmModel`]: what its E-step and M-step do, and how far an M-step moved
//! it. [`run_em`] owns the rest: the widths (a fixed schedule, Dewaele et al. 2006 sec. 4
//! and Cannavò et al. 2020's deterministic annealing; or the width the M-step estimates,
//! Cagniart et al. 2010 eq. 15, falling no faster than an annealing rate), the iterations
//! per width, and when to stop.

use crate::math::{Matrix3, Quat, Trs};

/// Where the loop is, as the model's steps see it.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Stage {
    /// The kernel width of this iteration.
    pub sigma: f64,
    /// The width's index in a fixed schedule (0 when the M-step sets the width).
    pub level: usize,
    /// Whether this is the schedule's last width (always, when the M-step sets the width).
    pub last_level: bool,
    /// Iterations so far, this one included (from 1).
    pub iteration: usize,
    /// Whether this iteration is one of the schedule's preliminary ones (never the last).
    pub preliminary: bool,
}

/// What an E-step found.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Expectation {
    /// Correspondences are ready for the M-step.
    Ready,
    /// No datum supports the model: a preliminary iteration is skipped, any other ends the
    /// loop.
    NoSupport,
    /// The correspondences no longer change: the loop ends before the M-step.
    Settled,
}

/// What an M-step did.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Maximisation {
    /// How far the model moved (in the units of [`Schedule::tolerance`]).
    pub moved: f64,
    /// The width the data now supports, when the model estimates one (Cagniart eq. 15).
    pub sigma_estimate: Option<f64>,
}

impl Maximisation {
    /// A move with no width estimate.
    pub fn moved(moved: f64) -> Self {
        Self {
            moved,
            sigma_estimate: None,
        }
    }
}

/// A model the loop fits: its E-step and its M-step at a [`Stage`].
pub trait EmModel {
    type Error;

    /// Prepares a new width of a fixed schedule (coarse representatives, neighbour lists).
    fn begin_level(&mut self, _stage: &Stage) -> Result<(), Self::Error> {
        Ok(())
    }

    /// Whether to stop now (an interrupt): checked before each E-step.
    fn interrupted(&self) -> bool {
        false
    }

    /// The E-step at `stage.sigma`.
    fn e_step(&mut self, stage: &Stage) -> Result<Expectation, Self::Error>;

    /// The M-step from the last E-step's correspondences.
    fn m_step(&mut self, stage: &Stage) -> Result<Maximisation, Self::Error>;
}

/// The widths the loop anneals through.
#[derive(Clone, Debug, PartialEq)]
pub enum Widths {
    /// `start * ratio^level` for `level` in `0..=steps` (Dewaele sec. 4: geometric).
    Geometric {
        start: f64,
        ratio: f64,
        steps: usize,
    },
    /// The given widths, in order (a precomputed schedule).
    List(Vec<f64>),
    /// One level whose width the M-step sets: `max(estimate, fall * sigma, floor)` from
    /// `start` (Cagniart eq. 15, annealed). The first `preliminary` iterations never end the
    /// loop by convergence. While the model still travels (its last M-step moved it more
    /// than `hold` times the width), the width does not fall, so that a part on its way to
    /// its data is not cut off from it (0: it always falls).
    Estimated {
        start: f64,
        floor: f64,
        fall: f64,
        preliminary: usize,
        hold: f64,
    },
}

impl Widths {
    fn levels(&self) -> usize {
        match self {
            Widths::Geometric { steps, .. } => steps + 1,
            Widths::List(widths) => widths.len(),
            Widths::Estimated { .. } => 1,
        }
    }

    fn at(&self, level: usize) -> f64 {
        match self {
            Widths::Geometric { start, ratio, .. } => start * ratio.powi(level as i32),
            Widths::List(widths) => widths[level],
            Widths::Estimated { start, .. } => *start,
        }
    }
}

/// How the loop anneals and when it stops.
#[derive(Clone, Debug, PartialEq)]
pub struct Schedule {
    pub widths: Widths,
    /// EM iterations at each width but the last.
    pub rounds: usize,
    /// EM iterations at the last width, at most.
    pub final_rounds: usize,
    /// At the last width (past any preliminary iterations, with the width no longer held up
    /// by the annealing rate), the loop ends once an M-step moves the model less than this;
    /// `None`: it runs every iteration.
    pub tolerance: Option<f64>,
}

/// Why the loop ended.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Ending {
    /// Every iteration of the schedule ran.
    Exhausted,
    /// The model stopped moving at the last width.
    Converged,
    /// The E-step found the correspondences unchanged.
    Settled,
    /// The E-step found no datum supporting the model.
    NoSupport,
    /// [`EmModel::interrupted`] said so.
    Interrupted,
}

/// What the loop did.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct LoopReport {
    /// EM iterations begun (skipped preliminary ones included).
    pub iterations: usize,
    /// The width at the end.
    pub sigma: f64,
    pub ending: Ending,
}

/// Fits `model` by EM through `schedule`'s widths.
pub fn run_em<M: EmModel>(model: &mut M, schedule: &Schedule) -> Result<LoopReport, M::Error> {
    let levels = schedule.widths.levels();
    let mut iterations = 0;
    // An empty schedule runs nothing and reports no width.
    let mut sigma = if levels > 0 {
        schedule.widths.at(0)
    } else {
        0.0
    };
    let preliminary = match schedule.widths {
        Widths::Estimated { preliminary, .. } => preliminary,
        _ => 0,
    };
    for level in 0..levels {
        let last_level = level + 1 == levels;
        sigma = schedule.widths.at(level);
        let rounds = if last_level {
            schedule.final_rounds
        } else {
            schedule.rounds
        };
        let mut stage = Stage {
            sigma,
            level,
            last_level,
            iteration: iterations,
            preliminary: false,
        };
        model.begin_level(&stage)?;
        for _ in 0..rounds {
            if model.interrupted() {
                return Ok(report(iterations, sigma, Ending::Interrupted));
            }
            iterations += 1;
            stage.iteration = iterations;
            stage.sigma = sigma;
            stage.preliminary = iterations <= preliminary;
            match model.e_step(&stage)? {
                Expectation::Ready => {}
                Expectation::NoSupport if stage.preliminary => continue,
                Expectation::NoSupport => return Ok(report(iterations, sigma, Ending::NoSupport)),
                Expectation::Settled => return Ok(report(iterations, sigma, Ending::Settled)),
            }
            let step = model.m_step(&stage)?;
            // A width the data supports falls no faster than the annealing rate allows; the
            // loop cannot end while the rate holds it up.
            let mut held_up = false;
            if let (
                Widths::Estimated {
                    floor, fall, hold, ..
                },
                Some(estimate),
            ) = (&schedule.widths, step.sigma_estimate)
            {
                held_up = estimate < sigma * fall && sigma > *floor;
                let travelling = *hold > 0.0 && step.moved > hold * sigma;
                let fall = if travelling { 1.0 } else { *fall };
                sigma = estimate.max(sigma * fall).max(*floor);
            }
            let converged = schedule
                .tolerance
                .is_some_and(|tolerance| step.moved < tolerance);
            if last_level && converged && !held_up && !stage.preliminary {
                return Ok(report(iterations, sigma, Ending::Converged));
            }
        }
    }
    Ok(report(iterations, sigma, Ending::Exhausted))
}

fn report(iterations: usize, sigma: f64, ending: Ending) -> LoopReport {
    LoopReport {
        iterations,
        sigma,
        ending,
    }
}

/// Prediction for the next frame: `current` moved on by `gain` times the motion from
/// `previous` (constant velocity; the turn continued about its own axis).
pub fn continued_trs(previous: &Trs, current: &Trs, gain: f64) -> (crate::math::Vector3, Quat) {
    let translation = current.translation + (current.translation - previous.translation) * gain;
    let step = (previous.rotation.inverse() * current.rotation).scaled_axis() * gain;
    let rotation =
        Quat::new_normalize((current.rotation * Quat::from_scaled_axis(step)).into_inner());
    (translation, rotation)
}

/// Prediction for the next frame of a rotation matrix: the last turn applied once more.
pub fn continued_rotation(previous: &Matrix3, current: &Matrix3) -> Matrix3 {
    let turn = current * previous.transpose();
    turn * current
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A model whose M-step halves its distance to zero and whose data never runs out.
    struct Halving {
        value: f64,
        seen: Vec<Stage>,
        estimate: Option<f64>,
    }

    impl EmModel for Halving {
        type Error = ();
        fn e_step(&mut self, stage: &Stage) -> Result<Expectation, ()> {
            self.seen.push(*stage);
            Ok(Expectation::Ready)
        }
        fn m_step(&mut self, _stage: &Stage) -> Result<Maximisation, ()> {
            let before = self.value;
            self.value *= 0.5;
            Ok(Maximisation {
                moved: before - self.value,
                sigma_estimate: self.estimate,
            })
        }
    }

    fn halving(estimate: Option<f64>) -> Halving {
        Halving {
            value: 1.0,
            seen: Vec::new(),
            estimate,
        }
    }

    #[test]
    fn a_geometric_schedule_runs_its_rounds_and_stops_at_the_last_width() {
        let schedule = Schedule {
            widths: Widths::Geometric {
                start: 1.0,
                ratio: 0.5,
                steps: 2,
            },
            rounds: 2,
            final_rounds: 10,
            tolerance: Some(0.01),
        };
        let mut model = halving(None);
        let report = run_em(&mut model, &schedule).expect("runs");
        let sigmas: Vec<f64> = model.seen.iter().map(|s| s.sigma).collect();
        // Two rounds at 1 and 0.5 (never stopping there), then at 0.25 until a move < 0.01.
        assert_eq!(&sigmas[..4], &[1.0, 1.0, 0.5, 0.5]);
        assert!(sigmas[4..].iter().all(|&s| s == 0.25));
        assert_eq!(report.ending, Ending::Converged);
        assert_eq!(report.iterations, model.seen.len());
        assert!(model.value < 0.02);
    }

    #[test]
    fn an_estimated_width_falls_no_faster_than_the_annealing_rate() {
        let schedule = Schedule {
            widths: Widths::Estimated {
                start: 1.0,
                floor: 0.1,
                fall: 0.5,
                preliminary: 1,
                hold: 0.0,
            },
            rounds: 0,
            final_rounds: 20,
            tolerance: Some(1.0),
        };
        // The data claims a tiny width: it falls by half per iteration down to the floor,
        // and the loop cannot stop while the rate holds it up.
        let mut model = halving(Some(1e-6));
        let report = run_em(&mut model, &schedule).expect("runs");
        let sigmas: Vec<f64> = model.seen.iter().map(|s| s.sigma).collect();
        assert_eq!(&sigmas[..4], &[1.0, 0.5, 0.25, 0.125]);
        assert!(model.seen[0].preliminary && !model.seen[1].preliminary);
        assert_eq!(report.sigma, 0.1);
        assert_eq!(report.ending, Ending::Converged);
    }

    #[test]
    fn an_estimated_width_holds_while_the_model_travels() {
        let schedule = Schedule {
            widths: Widths::Estimated {
                start: 1.0,
                floor: 0.1,
                fall: 0.5,
                preliminary: 0,
                hold: 0.4,
            },
            rounds: 0,
            final_rounds: 20,
            tolerance: Some(1e-3),
        };
        // The first step moves 0.5, more than 0.4 of the width: the width stays; the next
        // ones move less than that and it falls at the annealing rate.
        let mut model = halving(Some(1e-6));
        run_em(&mut model, &schedule).expect("runs");
        let sigmas: Vec<f64> = model.seen.iter().map(|s| s.sigma).collect();
        assert_eq!(&sigmas[..4], &[1.0, 1.0, 0.5, 0.25]);
    }

    #[test]
    fn continued_motion_turns_as_much_again() {
        let previous = Trs::new(
            crate::math::Vector3::zeros(),
            Quat::from_axis_angle(&crate::math::Vector3::z_axis(), 0.1),
        );
        let current = Trs::new(
            crate::math::Vector3::new(1.0, 0.0, 0.0),
            Quat::from_axis_angle(&crate::math::Vector3::z_axis(), 0.3),
        );
        let (t, r) = continued_trs(&previous, &current, 1.0);
        assert!((t.x - 2.0).abs() < 1e-12);
        assert!((r.angle() - 0.5).abs() < 1e-12);
        let m = continued_rotation(
            previous.rotation.to_rotation_matrix().matrix(),
            current.rotation.to_rotation_matrix().matrix(),
        );
        let expected = Quat::from_axis_angle(&crate::math::Vector3::z_axis(), 0.5);
        assert!((m - expected.to_rotation_matrix().matrix()).norm() < 1e-12);
    }
}
