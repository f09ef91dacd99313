//! TEMPORARY: the API of `rigfit_core::interrupt` and `solve_pose_interruptible` (being added
//! to rigfit-core on main) so the server builds until that lands; this solve is not
//! interruptible. Deleted when main is merged.

use std::sync::Arc;
use std::sync::atomic::{AtomicBool, Ordering};
use std::time::Instant;

use rigfit_core::pose::{PoseError, PoseOptions, PoseProblem, PoseResult, solve_pose};

#[derive(Clone, Debug, Default)]
pub struct Interrupt {
    deadline: Option<Instant>,
    flag: Option<Arc<AtomicBool>>,
}

impl Interrupt {
    pub fn never() -> Self {
        Self::default()
    }

    pub fn with_deadline(mut self, deadline: Instant) -> Self {
        self.deadline = Some(deadline);
        self
    }

    pub fn with_flag(mut self, flag: Arc<AtomicBool>) -> Self {
        self.flag = Some(flag);
        self
    }

    pub fn is_set(&self) -> bool {
        self.flag
            .as_ref()
            .is_some_and(|f| f.load(Ordering::Relaxed))
            || self.deadline.is_some_and(|d| Instant::now() >= d)
    }
}

pub fn solve_pose_interruptible(
    problem: &PoseProblem,
    options: &PoseOptions,
    _interrupt: &Interrupt,
) -> Result<PoseResult, PoseError> {
    solve_pose(problem, options)
}
