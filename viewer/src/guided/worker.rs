//! A background worker where the newest request wins: one job runs at a time on
//! its own thread; a request waits in a single slot, replacing the one waiting
//! there (which is then never run); and a request can cancel the running job
//! through its [`Cancel`] flag, which the job checks (the guided search does, before
//! every particle-step). Every request is answered exactly once through the
//! `deliver` callback: with the job's result, or `None` when it was replaced,
//! cancelled or the worker stopped first — so a caller that counts answers knows
//! when nothing is left in flight.
//!
//! Generic over the job, so its scheduling is tested without a grammar; the editor's
//! job is [`super::search::run_search`].

use mdg_guided::Cancel;
use std::sync::{Arc, Condvar, Mutex, MutexGuard};
use std::thread::JoinHandle;

/// Whether a new request stops the running job.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Preempt {
    /// Cancel the running job: its answer is `None` and the new request runs next.
    Cancel,
    /// Let the running job finish (its answer is delivered); the new request runs
    /// after it. While a control point is dragged this keeps results coming at the
    /// rate searches finish instead of cancelling each one before it is done.
    Wait,
}

struct State<R> {
    waiting: Option<(u64, R)>,
    running: Option<(u64, Cancel)>,
    next_id: u64,
    stop: bool,
}

struct Shared<R> {
    state: Mutex<State<R>>,
    wake: Condvar,
}

fn lock<T>(m: &Mutex<T>) -> MutexGuard<'_, T> {
    m.lock().unwrap_or_else(|e| e.into_inner())
}

type Deliver<O> = Arc<dyn Fn(u64, Option<O>) + Send + Sync>;

/// The worker; dropping it cancels the running job and joins the thread.
pub struct Worker<R: Send + 'static, O: Send + 'static> {
    shared: Arc<Shared<R>>,
    deliver: Deliver<O>,
    thread: Option<JoinHandle<()>>,
}

impl<R: Send + 'static, O: Send + 'static> Worker<R, O> {
    /// Starts the thread (named `name`). `run` does one job, checking the flag to
    /// stop early; `deliver` receives each request's id and answer (from the worker
    /// thread, or from the thread that submitted a request that replaced one).
    pub fn start(
        name: &str,
        run: impl Fn(R, &Cancel) -> O + Send + 'static,
        deliver: impl Fn(u64, Option<O>) + Send + Sync + 'static,
    ) -> Result<Worker<R, O>, crate::ThreadError> {
        let shared = Arc::new(Shared {
            state: Mutex::new(State { waiting: None, running: None, next_id: 1, stop: false }),
            wake: Condvar::new(),
        });
        let deliver: Deliver<O> = Arc::new(deliver);
        let (sh, out) = (shared.clone(), deliver.clone());
        let thread = std::thread::Builder::new()
            .name(name.to_string())
            .spawn(move || loop {
                let (id, request, cancel) = {
                    let mut st = lock(&sh.state);
                    loop {
                        if st.stop {
                            return;
                        }
                        if let Some((id, r)) = st.waiting.take() {
                            let cancel = Cancel::new();
                            st.running = Some((id, cancel.clone()));
                            break (id, r, cancel);
                        }
                        st = sh.wake.wait(st).unwrap_or_else(|e| e.into_inner());
                    }
                };
                let result = run(request, &cancel);
                out(id, (!cancel.is_cancelled()).then_some(result));
                lock(&sh.state).running = None;
                sh.wake.notify_all();
            })
            .map_err(|error| crate::ThreadError { what: format!("the {name} thread"), error })?;
        Ok(Worker { shared, deliver, thread: Some(thread) })
    }

    /// Queues `request` (replacing one still waiting, answered `None`) and returns
    /// its id (increasing from 1).
    pub fn submit(&self, request: R, preempt: Preempt) -> u64 {
        let replaced = {
            let mut st = lock(&self.shared.state);
            let id = st.next_id;
            st.next_id += 1;
            if preempt == Preempt::Cancel {
                if let Some((_, c)) = &st.running {
                    c.cancel();
                }
            }
            let old = st.waiting.replace((id, request)).map(|(old, _)| old);
            self.shared.wake.notify_all();
            (id, old)
        };
        if let Some(old) = replaced.1 {
            (self.deliver)(old, None);
        }
        replaced.0
    }

    /// Whether a job is running or waiting.
    pub fn is_busy(&self) -> bool {
        let st = lock(&self.shared.state);
        st.running.is_some() || st.waiting.is_some()
    }
}

impl<R: Send + 'static, O: Send + 'static> Drop for Worker<R, O> {
    fn drop(&mut self) {
        {
            let mut st = lock(&self.shared.state);
            st.stop = true;
            if let Some((_, c)) = &st.running {
                c.cancel();
            }
            st.waiting = None;
            self.shared.wake.notify_all();
        }
        if let Some(t) = self.thread.take() {
            let _ = t.join();
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use std::sync::mpsc;
    use std::time::{Duration, Instant};

    /// How long a test waits for what should come at once before it calls it a hang:
    /// long, since tests share a loaded machine (timings are benchmarks' business).
    const HANG: Duration = Duration::from_secs(60);

    /// A job that runs until released through its gate (or cancelled), then returns
    /// its number.
    type Job = (u32, Arc<(Mutex<bool>, Condvar)>);

    fn gate() -> Arc<(Mutex<bool>, Condvar)> {
        Arc::new((Mutex::new(false), Condvar::new()))
    }

    fn open(g: &Arc<(Mutex<bool>, Condvar)>) {
        *lock(&g.0) = true;
        g.1.notify_all();
    }

    fn run((n, g): Job, cancel: &Cancel) -> u32 {
        let mut open = lock(&g.0);
        while !*open && !cancel.is_cancelled() {
            open = g.1.wait_timeout(open, Duration::from_millis(2)).map(|r| r.0).unwrap_or_else(|e| e.into_inner().0);
        }
        n
    }

    /// Answers as the worker delivers them.
    type Answers = mpsc::Receiver<(u64, Option<u32>)>;

    fn worker() -> (Worker<Job, u32>, Answers) {
        let (tx, rx) = mpsc::channel();
        let tx = Mutex::new(tx);
        let w = Worker::start("test-worker", run, move |id, out| {
            let _ = lock(&tx).send((id, out));
        })
        .expect("thread");
        (w, rx)
    }

    fn wait_running(w: &Worker<Job, u32>) {
        let deadline = Instant::now() + HANG;
        while lock(&w.shared.state).running.is_none() {
            assert!(Instant::now() < deadline, "the job never started");
            std::thread::sleep(Duration::from_millis(1));
        }
    }

    #[test]
    fn the_newest_waiting_request_replaces_older_ones_and_the_running_one_finishes() {
        let (w, rx) = worker();
        let g1 = gate();
        let first = w.submit((1, g1.clone()), Preempt::Wait);
        wait_running(&w);
        let second = w.submit((2, gate()), Preempt::Wait);
        let g3 = gate();
        open(&g3);
        let third = w.submit((3, g3), Preempt::Wait);
        assert_eq!((first, second, third), (1, 2, 3));
        // The second never runs: answered at once. (The timeouts here and below are hang
        // guards, long for a loaded machine.)
        assert_eq!(rx.recv_timeout(HANG).expect("answer"), (2, None));
        assert!(w.is_busy());
        open(&g1);
        assert_eq!(rx.recv_timeout(HANG).expect("answer"), (1, Some(1)));
        assert_eq!(rx.recv_timeout(HANG).expect("answer"), (3, Some(3)));
        let deadline = Instant::now() + HANG;
        while w.is_busy() {
            assert!(Instant::now() < deadline);
            std::thread::sleep(Duration::from_millis(1));
        }
    }

    #[test]
    fn a_cancelling_request_stops_the_running_job() {
        let (w, rx) = worker();
        let _stuck = w.submit((1, gate()), Preempt::Wait);
        wait_running(&w);
        let g = gate();
        open(&g);
        // The first job's gate never opens: only the cancel can end it.
        let id = w.submit((2, g), Preempt::Cancel);
        assert_eq!(rx.recv_timeout(HANG).expect("answer"), (1, None), "cancelled");
        assert_eq!(rx.recv_timeout(HANG).expect("answer"), (id, Some(2)));
        // Dropping the worker with a job stuck in it returns (the job is cancelled).
        let _ = w.submit((3, gate()), Preempt::Wait);
        wait_running(&w);
        drop(w);
    }
}
