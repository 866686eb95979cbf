//! Keeping the pool's workers awake through work that alternates between
//! one core and both.
//!
//! A fit of a few thousand starts alternates serial phases of a few
//! milliseconds (the symbolic analysis) with parallel ones (the numeric
//! factorisation's two halves). Rayon puts an idle worker to sleep within
//! microseconds, and on a two-core VM a sleeping worker took up to 3 ms to
//! wake (its virtual CPU halted): the next parallel phase then ran on one
//! core, every other fit of a 4,000-start scan (numeric 7.5 ms or 11.5 ms).
//! An OpenMP runtime keeps its threads spinning between parallel regions
//! for this reason; [`with_the_pool_awake`] does the same for one piece of
//! work.
//!
//! The waiting is done in short jobs ([`SPIN`] each), each queueing the
//! next until the work is done, never in one job that waits for the work:
//! a worker that took such a job while a job of the work lay suspended
//! under it on its stack would wait for work that waits for it (the first
//! form of this module hung the test suite so). And the work's own worker,
//! finding a waiting job on its deque while it waits, runs what lies under
//! it before queueing it again (two works at once on two workers hung
//! so: `broadcasts_inside_two_works_at_once_finish`).

use std::sync::Arc;
use std::sync::atomic::{AtomicBool, Ordering};
use std::time::{Duration, Instant};

/// How long one waiting job spins (running any job it finds meanwhile)
/// before it queues the next and returns.
const SPIN: Duration = Duration::from_micros(50);

/// The most workers kept awake beside the work's own: a larger pool's
/// others sleep as rayon has them (on a machine of many cores, burning them
/// all through a serial phase would cost more than their waking).
const MAX_AWAKE: usize = 3;

/// Runs `work` on the pool while up to [`MAX_AWAKE`] other workers wait
/// awake: each runs
/// short jobs that spin and run any job `work` hands out (its joins'
/// second halves) as an idle worker would, instead of sleeping, until
/// `work` returns or panics. Called from outside the pool, `work` moves to
/// one of its workers (the caller sleeps meanwhile: a spinning worker must
/// not take the core the work needs). Work of less than a millisecond gains
/// nothing here.
pub(crate) fn with_the_pool_awake<T: Send>(work: impl FnOnce() -> T + Send) -> T {
    if rayon::current_num_threads() < 2 {
        return work();
    }
    if rayon::current_thread_index().is_none() {
        return rayon::scope(|_| with_the_pool_awake(work));
    }
    /// Ends the waiting when the work ends, by return or by panic.
    struct Done(Arc<AtomicBool>);
    impl Drop for Done {
        fn drop(&mut self) {
            self.0.store(true, Ordering::Release);
        }
    }
    let done = Done(Arc::new(AtomicBool::new(false)));
    let home = rayon::current_thread_index();
    for _ in 1..rayon::current_num_threads().min(1 + MAX_AWAKE) {
        let flag = done.0.clone();
        rayon::spawn(move || wait_awake(flag, home));
    }
    work()
}

/// One waiting job: spins for [`SPIN`] (running what it finds), then
/// queues the next unless the work is done. On the work's own worker
/// (`home`), found there while it waits in one of the work's joins (or a
/// broadcast), it runs one pending job instead of spinning and passes the
/// waiting on: queued again on that worker's own deque, it would otherwise
/// be all the worker ever took back, above the very jobs it waits for.
fn wait_awake(done: Arc<AtomicBool>, home: Option<usize>) {
    if rayon::current_thread_index() == home {
        rayon::yield_now();
    } else {
        let end = Instant::now() + SPIN;
        while !done.load(Ordering::Acquire) && Instant::now() < end {
            if rayon::yield_now() != Some(rayon::Yield::Executed) {
                std::hint::spin_loop();
            }
        }
    }
    if !done.load(Ordering::Acquire) {
        rayon::spawn(move || wait_awake(done, home));
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn sum(v: &[u64]) -> u64 {
        if v.len() < 64 {
            return v.iter().sum();
        }
        let (a, b) = v.split_at(v.len() / 2);
        let (x, y) = rayon::join(|| sum(a), || sum(b));
        x + y
    }

    /// The work's own joins still run, on pools of one to four workers,
    /// called from a worker or from outside, nested, and give what they
    /// give without the waiting.
    #[test]
    fn work_with_joins_inside_completes_on_any_pool() {
        let v: Vec<u64> = (0..100_000).collect();
        let want: u64 = v.iter().sum();
        for threads in [1, 2, 4] {
            let pool = rayon::ThreadPoolBuilder::new()
                .num_threads(threads)
                .build()
                .expect("a pool");
            let got = pool.install(|| {
                with_the_pool_awake(|| sum(&v) + with_the_pool_awake(|| sum(&v[..10])))
            });
            assert_eq!(got, want + 45, "{threads} threads");
        }
        assert_eq!(with_the_pool_awake(|| sum(&v)), want);
    }

    /// `callers` threads each run `work` `rounds` times on one pool of
    /// `threads` workers; every result must be `want`, and all must come
    /// within a minute (a hang fails here, not as CI's timeout).
    fn callers_finish(
        threads: usize,
        callers: usize,
        rounds: usize,
        work: fn(&[u64]) -> u64,
        want: u64,
    ) {
        let pool = Arc::new(
            rayon::ThreadPoolBuilder::new()
                .num_threads(threads)
                .build()
                .expect("a pool"),
        );
        let v: Arc<Vec<u64>> = Arc::new((0..20_000).collect());
        let (tx, rx) = std::sync::mpsc::channel();
        for _ in 0..callers {
            let (pool, v, tx) = (pool.clone(), v.clone(), tx.clone());
            std::thread::spawn(move || {
                for _ in 0..rounds {
                    let got = pool.install(|| work(&v));
                    if tx.send(got).is_err() {
                        return;
                    }
                }
            });
        }
        for k in 0..callers * rounds {
            let got = rx
                .recv_timeout(Duration::from_secs(60))
                .unwrap_or_else(|e| panic!("{e}: hung after {k} of {} works", callers * rounds));
            assert_eq!(got, want);
        }
    }

    fn total() -> u64 {
        (0..20_000u64).sum()
    }

    /// Many callers at once, from outside the pool, each work waiting
    /// inside the other's join, nested.
    #[test]
    fn many_callers_at_once_all_finish() {
        fn work(v: &[u64]) -> u64 {
            let (a, b) = rayon::join(
                || with_the_pool_awake(|| sum(v)),
                || with_the_pool_awake(|| sum(v) + with_the_pool_awake(|| sum(&v[..10]))),
            );
            a + b
        }
        callers_finish(2, 4, 20, work, 2 * total() + 45);
        callers_finish(4, 3, 20, work, 2 * total() + 45);
    }

    /// A broadcast inside the work (the factorisation clears every
    /// worker's vector state with one) from two callers at once on two
    /// workers: each worker is the home of one work, and must still take
    /// its broadcast job and its joins' halves from under a waiting job.
    #[test]
    fn broadcasts_inside_two_works_at_once_finish() {
        fn work(v: &[u64]) -> u64 {
            with_the_pool_awake(|| {
                let a = sum(v);
                rayon::broadcast(|_| ());
                a + sum(v)
            })
        }
        callers_finish(2, 2, 100, work, 2 * total());
        callers_finish(4, 3, 50, work, 2 * total());
    }

    /// A panic in the work reaches the caller, and the pool goes on.
    #[test]
    fn a_panicking_work_ends_the_waiting() {
        let pool = rayon::ThreadPoolBuilder::new()
            .num_threads(2)
            .build()
            .expect("a pool");
        let caught = std::panic::catch_unwind(std::panic::AssertUnwindSafe(|| {
            pool.install(|| with_the_pool_awake(|| panic!("the work")))
        }));
        assert!(caught.is_err());
        assert_eq!(pool.install(|| with_the_pool_awake(|| 7)), 7);
    }
}
