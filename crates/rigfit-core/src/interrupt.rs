//! Stopping a solve from outside: a deadline, a flag another thread sets (a client that went
//! away, a shutdown), or both. Solvers poll [`Interrupt::is_set`] between iterations and
//! return early; the caller turns that into an error.

use std::sync::Arc;
use std::sync::atomic::{AtomicBool, Ordering};
use std::time::Instant;

/// When a solve must stop. The default never stops.
#[derive(Clone, Debug, Default)]
pub struct Interrupt {
    flag: Option<Arc<AtomicBool>>,
    deadline: Option<Instant>,
}

impl Interrupt {
    /// An interrupt that is never set.
    pub fn never() -> Self {
        Self::default()
    }

    /// Also set once `deadline` has passed.
    #[must_use]
    pub fn with_deadline(mut self, deadline: Instant) -> Self {
        self.deadline = Some(self.deadline.map_or(deadline, |d| d.min(deadline)));
        self
    }

    /// Also set once `flag` is true (another thread stores `true` to cancel).
    #[must_use]
    pub fn with_flag(mut self, flag: Arc<AtomicBool>) -> Self {
        self.flag = Some(flag);
        self
    }

    /// True once the flag is raised or the deadline has passed. Cheap enough to call once per
    /// solver iteration (an atomic load and, with a deadline, a clock read).
    pub fn is_set(&self) -> bool {
        self.flag
            .as_ref()
            .is_some_and(|f| f.load(Ordering::Relaxed))
            || self.deadline.is_some_and(|d| Instant::now() >= d)
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use std::time::Duration;

    #[test]
    fn never_is_never_set() {
        assert!(!Interrupt::never().is_set());
    }

    #[test]
    fn flag_and_deadline_set_it() {
        let flag = Arc::new(AtomicBool::new(false));
        let interrupt = Interrupt::never().with_flag(flag.clone());
        assert!(!interrupt.is_set());
        flag.store(true, Ordering::Relaxed);
        assert!(interrupt.is_set());
        let past = Interrupt::never().with_deadline(Instant::now());
        assert!(past.is_set());
        let future = Interrupt::never().with_deadline(Instant::now() + Duration::from_secs(60));
        assert!(!future.is_set());
        // The earlier of two deadlines wins.
        assert!(future.with_deadline(Instant::now()).is_set());
    }
}
