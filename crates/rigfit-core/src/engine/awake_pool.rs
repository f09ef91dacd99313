//! Runs a piece of work made of many short parallel loops with the thread pool's other
//! workers kept awake between them ([`run_with_workers_awake`]).
//!
//! A rayon worker with nothing to do soon goes to sleep, and waking it costs tens of
//! microseconds on a virtual machine: a parallel loop started after a stretch of serial code
//! ran on one thread until the sleeper woke (a 40 us loop gained nothing from a second core).
//! A surface-tracking frame has about a hundred such loops. Here each other worker runs a
//! keeper while the work lasts: it takes whatever jobs the loops offer and, between them,
//! spins instead of sleeping.

use std::sync::atomic::{AtomicBool, Ordering};
use std::time::{Duration, Instant};

/// How long a keeper spins without a job before it hands its thread back (and queues itself
/// again). Below it on the thread's stack there may be a job waiting for its own loop to
/// finish; handing back often bounds that wait.
const KEEPER_IDLE: Duration = Duration::from_micros(50);

/// Runs `work` on the current rayon pool with its other workers kept awake until it returns
/// (or unwinds). With one thread in the pool it is `rayon::scope(|_| work())`.
pub fn run_with_workers_awake<R: Send>(work: impl FnOnce() -> R + Send) -> R {
    let done = AtomicBool::new(false);
    rayon::scope(|scope| {
        // Set when `work` returns or unwinds, so that the keepers stop and the scope ends.
        struct Finished<'a>(&'a AtomicBool);
        impl Drop for Finished<'_> {
            fn drop(&mut self) {
                self.0.store(true, Ordering::Release);
            }
        }
        let finished = Finished(&done);
        let runner = rayon::current_thread_index();
        for _ in 1..rayon::current_num_threads() {
            let done = &done;
            scope.spawn(move |scope| keep_awake(scope, done, runner));
        }
        let result = work();
        drop(finished);
        result
    })
}

/// A keeper: on a worker other than the one running the work, runs the jobs the pool offers
/// and spins between them until `done`, handing its thread back after [`KEEPER_IDLE`]
/// without a job (it queues itself again first). On the work's own worker (it found the
/// keeper while waiting) it only queues itself again.
fn keep_awake<'s>(scope: &rayon::Scope<'s>, done: &'s AtomicBool, runner: Option<usize>) {
    if done.load(Ordering::Acquire) {
        return;
    }
    if rayon::current_thread_index() != runner {
        let mut idle_since = Instant::now();
        let mut idle_rounds = 0u32;
        while !done.load(Ordering::Acquire) {
            if let Some(rayon::Yield::Executed) = rayon::yield_now() {
                (idle_since, idle_rounds) = (Instant::now(), 0);
                continue;
            }
            idle_rounds += 1;
            // The clock is read once in a while only: reading it costs as much as a round.
            if idle_rounds % 64 == 0 && idle_since.elapsed() > KEEPER_IDLE {
                break;
            }
            std::hint::spin_loop();
        }
        if done.load(Ordering::Acquire) {
            return;
        }
    }
    scope.spawn(move |scope| keep_awake(scope, done, runner));
}

#[cfg(test)]
mod tests {
    use super::*;
    use rayon::prelude::*;

    /// The work's result comes back; nested parallel loops, serial stretches and a panic
    /// inside the work all end the keepers (no hang).
    #[test]
    fn returns_the_work_and_ends_its_keepers() {
        let pool = rayon::ThreadPoolBuilder::new()
            .num_threads(3)
            .build()
            .expect("pool");
        let total = pool.install(|| {
            run_with_workers_awake(|| {
                let mut total = 0u64;
                for round in 0..200u64 {
                    let start = Instant::now();
                    while start.elapsed() < Duration::from_micros(round % 7 * 20) {}
                    total += (0..10_000u64)
                        .into_par_iter()
                        .map(|i| (0..3u64).into_par_iter().map(|j| i * j).sum::<u64>())
                        .sum::<u64>();
                }
                total
            })
        });
        assert_eq!(total, 200 * (0..10_000u64).map(|i| 3 * i).sum::<u64>());
        let caught = std::panic::catch_unwind(std::panic::AssertUnwindSafe(|| {
            pool.install(|| run_with_workers_awake(|| panic!("inside the work")))
        }));
        assert!(caught.is_err());
        // Two pieces of work side by side in one pool, each keeping the other's workers.
        let (a, b) = pool.install(|| {
            rayon::join(
                || run_with_workers_awake(|| (0..100_000u64).into_par_iter().sum::<u64>()),
                || run_with_workers_awake(|| (0..50_000u64).into_par_iter().sum::<u64>()),
            )
        });
        assert_eq!((a, b), (4_999_950_000, 1_249_975_000));
        // With one thread, the work runs alone.
        let single = rayon::ThreadPoolBuilder::new()
            .num_threads(1)
            .build()
            .expect("pool");
        assert_eq!(single.install(|| run_with_workers_awake(|| 7)), 7);
    }
}
