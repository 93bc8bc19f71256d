//! A team of threads that stays awake for the length of one search.
//!
//! A guided search runs ~100 generations of ~60 particle-steps each, about 80 µs of
//! work per generation on the Calder-sized workload. Handing each generation to
//! rayon's pool cost more than it saved on the 2-core machine measured: its workers
//! go to sleep between generations, and waking them takes tens of microseconds. The
//! team's helpers spin instead for a short while ([`SPIN_FOR`]) and only then park, so
//! back-to-back rounds cost a few atomic operations per helper, while a machine with
//! fewer free cores than threads is not held up by spinning for long.
//!
//! [`Team::round`] runs `member(t)` for every member t: member 0 on the calling
//! thread, the others on the helpers, and returns when all are done. Members share
//! data through the locks of the caller's own state (each member locking its own part
//! uncontended). A panic in a helper's round is carried to the caller and resumed
//! there, as rayon would, instead of leaving it waiting forever.

use std::any::Any;
use std::panic::{catch_unwind, resume_unwind, AssertUnwindSafe};
use std::sync::atomic::{AtomicBool, AtomicU64, Ordering};
use std::sync::Mutex;
use std::thread::{Scope, Thread};
use std::time::{Duration, Instant};

/// How long a waiting thread spins before it parks.
pub const SPIN_FOR: Duration = Duration::from_micros(100);
/// The longest a parked thread sleeps before it looks again (a safety net: every
/// change it waits for also unparks it).
const PARK_FOR: Duration = Duration::from_millis(1);

/// The shared counters of a team.
pub struct Team<'m> {
    member: &'m (dyn Fn(usize) + Sync),
    helpers: usize,
    /// Rounds started.
    round: AtomicU64,
    /// Helper rounds finished, over all rounds (`helpers` per round).
    done: AtomicU64,
    stop: AtomicBool,
    panic: Mutex<Option<Box<dyn Any + Send>>>,
    /// The calling thread (helpers unpark it when they finish a round) and the helpers.
    lead: Thread,
    threads: Mutex<Vec<Thread>>,
}

impl<'m> Team<'m> {
    /// Runs `lead` with a team of `threads` members (the calling thread and
    /// `threads − 1` helpers spawned in a scope; none for 0 or 1). `member(t)` is what
    /// member t does in each round; `lead` starts rounds with [`Team::round`].
    pub fn run<R>(threads: usize, member: &'m (dyn Fn(usize) + Sync), lead: impl FnOnce(&Team<'m>) -> R) -> R {
        let team = Team {
            member,
            helpers: threads.saturating_sub(1),
            round: AtomicU64::new(0),
            done: AtomicU64::new(0),
            stop: AtomicBool::new(false),
            panic: Mutex::new(None),
            lead: std::thread::current(),
            threads: Mutex::new(Vec::new()),
        };
        if team.helpers == 0 {
            return lead(&team);
        }
        std::thread::scope(|s: &Scope| {
            for t in 1..=team.helpers {
                let team = &team;
                let h = s.spawn(move || team.helper(t));
                team.threads.lock().unwrap_or_else(|e| e.into_inner()).push(h.thread().clone());
            }
            // Stop the helpers however `lead` ends (also when it panics).
            struct StopOnDrop<'t, 'm>(&'t Team<'m>);
            impl Drop for StopOnDrop<'_, '_> {
                fn drop(&mut self) {
                    self.0.stop.store(true, Ordering::Release);
                    self.0.unpark_helpers();
                }
            }
            let _stop = StopOnDrop(&team);
            lead(&team)
        })
    }

    /// One round: `member(t)` for every member, member 0 here. Returns when all are done.
    pub fn round(&self) {
        let r = self.round.fetch_add(1, Ordering::AcqRel) + 1;
        self.unpark_helpers();
        let here = catch_unwind(AssertUnwindSafe(|| (self.member)(0)));
        let want = r * self.helpers as u64;
        let mut waiting = Waiting::new();
        while self.done.load(Ordering::Acquire) < want {
            waiting.wait();
        }
        if let Err(p) = here {
            resume_unwind(p);
        }
        let carried = self.panic.lock().unwrap_or_else(|e| e.into_inner()).take();
        if let Some(p) = carried {
            resume_unwind(p);
        }
    }

    /// The number of members (the calling thread and the helpers).
    pub fn members(&self) -> usize {
        self.helpers + 1
    }

    fn unpark_helpers(&self) {
        for t in self.threads.lock().unwrap_or_else(|e| e.into_inner()).iter() {
            t.unpark();
        }
    }

    fn helper(&self, t: usize) {
        let mut seen = 0u64;
        let mut waiting = Waiting::new();
        loop {
            if self.stop.load(Ordering::Acquire) {
                return;
            }
            let r = self.round.load(Ordering::Acquire);
            if r == seen {
                waiting.wait();
                continue;
            }
            seen = r;
            if let Err(p) = catch_unwind(AssertUnwindSafe(|| (self.member)(t))) {
                self.panic.lock().unwrap_or_else(|e| e.into_inner()).get_or_insert(p);
            }
            self.done.fetch_add(1, Ordering::AcqRel);
            self.lead.unpark();
            waiting = Waiting::new();
        }
    }
}

/// Spinning for [`SPIN_FOR`], then parking (see the module documentation).
struct Waiting {
    since: Instant,
    spins: u32,
}

impl Waiting {
    fn new() -> Waiting {
        Waiting { since: Instant::now(), spins: 0 }
    }

    fn wait(&mut self) {
        self.spins = self.spins.wrapping_add(1);
        if !self.spins.is_multiple_of(64) || self.since.elapsed() < SPIN_FOR {
            std::hint::spin_loop();
        } else {
            std::thread::park_timeout(PARK_FOR);
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use std::sync::atomic::AtomicUsize;

    #[test]
    fn every_member_runs_once_per_round() {
        for threads in [0, 1, 2, 4] {
            let hits: Vec<AtomicUsize> = (0..threads.max(1)).map(|_| AtomicUsize::new(0)).collect();
            let member = |t: usize| {
                hits[t].fetch_add(1, Ordering::Relaxed);
            };
            Team::run(threads, &member, |team| {
                assert_eq!(team.members(), threads.max(1));
                for _ in 0..100 {
                    team.round();
                }
            });
            for h in &hits {
                assert_eq!(h.load(Ordering::Relaxed), 100, "{threads} threads");
            }
        }
    }

    #[test]
    fn a_helper_panic_reaches_the_caller() {
        let member = |t: usize| {
            if t == 1 {
                panic!("member 1 fails");
            }
        };
        let r = catch_unwind(AssertUnwindSafe(|| Team::run(2, &member, |team| team.round())));
        assert!(r.is_err());
    }
}
