//! The geometry's chunks smoothed on a thread of their own: a [`Stream`]
//! given a [`Worker`] hands each chunk it can work out to the worker, and
//! takes the result back in order when it needs the stations, so that the
//! look-ahead's thread (the node's control loop) never waits tens of
//! milliseconds for a chunk. The result is the same as on the stream's
//! own thread: the chunk's input is copied, and the worker runs the same
//! function on it. If the thread cannot be started or dies, the stream
//! smooths the chunk itself.
//!
//! [`Stream`]: super::Stream

use super::{smooth_range, Pl, SmoothError, DS};
use std::collections::VecDeque;
use std::sync::mpsc::{channel, Receiver, Sender, TryRecvError};
use std::sync::Arc;

/// What smoothing one chunk reads: grid points `i0..i1` with `a..b`
/// around them (their places `s` on the programmed path), and the
/// programmed path around them (arc length, point, feed).
pub(super) struct Job {
    pub i0: usize,
    pub i1: usize,
    pub a: usize,
    pub b: usize,
    pub s: Vec<f64>,
    pub rs: Vec<f64>,
    pub rp: Vec<[f64; 3]>,
    pub rf: Vec<f64>,
}

/// A chunk smoothed: the points `q` and widths `w` of grid points `a..b`,
/// the programmed path's points `p` there, and the feed at `i0..i1`.
pub(super) struct Done {
    pub q: Vec<[f64; 3]>,
    pub w: Vec<f64>,
    pub p: Vec<[f64; 3]>,
    pub feed: Vec<f64>,
}

impl Job {
    /// Smooths the chunk within `tol` (the shrink made up if `twice`).
    pub fn smooth(&self, tol: f64, twice: bool) -> Result<Done, SmoothError> {
        let path = Pl::new(&self.rs, &self.rp, None);
        let p: Vec<[f64; 3]> = self.s.iter().map(|x| path.value(*x)).collect();
        let (q, w) = smooth_range(&path, &self.s, &p, DS, tol, twice)?;
        let feed_line: Vec<[f64; 3]> = self.rf.iter().map(|f| [*f, 0.0, 0.0]).collect();
        let feed_pl = Pl::new(&self.rs, &feed_line, None);
        let feed = (self.i0..self.i1)
            .map(|i| feed_pl.value(self.s[i - self.a])[0])
            .collect();
        Ok(Done { q, w, p, feed })
    }
}

/// One chunk on its way to the worker and back.
struct Task {
    job: Arc<Job>,
    tol: f64,
    twice: bool,
    reply: Sender<Result<Done, SmoothError>>,
}

/// What comes back for one chunk.
type Reply = Receiver<Result<Done, SmoothError>>;

/// A thread that smooths chunks, shared by every stream given it; it ends
/// when the worker and every stream's link to it are dropped.
pub struct Worker {
    tx: Sender<Task>,
}

impl Worker {
    /// Starts the thread (which first calls `on_start`, e.g. to leave a
    /// real-time priority it inherited); `None` if it cannot be started.
    pub fn spawn(on_start: fn()) -> Option<Worker> {
        let (tx, rx) = channel::<Task>();
        std::thread::Builder::new()
            .name("path-geometry".into())
            .spawn(move || {
                on_start();
                while let Ok(t) = rx.recv() {
                    // (a stream dropped meanwhile no longer listens)
                    let _ = t.reply.send(t.job.smooth(t.tol, t.twice));
                }
            })
            .ok()?;
        Some(Worker { tx })
    }

    pub(super) fn link(&self) -> Link {
        Link {
            tx: Some(self.tx.clone()),
            pending: VecDeque::new(),
        }
    }
}

/// A stream's way to the worker: the chunks handed to it, oldest first.
pub(super) struct Link {
    /// `None` once the worker is found gone
    tx: Option<Sender<Task>>,
    /// chunks handed over and not taken back, each with the way its
    /// result comes (`None`: smoothed here)
    pending: VecDeque<(Arc<Job>, Option<Reply>)>,
}

impl Link {
    /// Hands `job` over (kept here to be smoothed on this thread if the
    /// worker is gone).
    pub fn send(&mut self, job: Job, tol: f64, twice: bool) {
        let job = Arc::new(job);
        let (reply, rx) = channel();
        let task = Task {
            job: job.clone(),
            tol,
            twice,
            reply,
        };
        let sent = self.tx.as_ref().is_some_and(|tx| tx.send(task).is_ok());
        if !sent {
            self.tx = None;
        }
        self.pending.push_back((job, sent.then_some(rx)));
    }

    /// The oldest chunk, if the worker has finished it (or, `wait`, once
    /// it has); smoothed here if the worker is gone.
    pub fn take(
        &mut self,
        tol: f64,
        twice: bool,
        wait: bool,
    ) -> Option<(Arc<Job>, Result<Done, SmoothError>)> {
        let (_, rx) = self.pending.front()?;
        let got = match rx {
            Some(rx) if wait => rx.recv().ok(),
            Some(rx) => match rx.try_recv() {
                Ok(d) => Some(d),
                Err(TryRecvError::Empty) => return None,
                Err(TryRecvError::Disconnected) => None,
            },
            None => None,
        };
        let (job, _) = self.pending.pop_front()?;
        // (no result: the worker is gone, and the chunk is smoothed here)
        let done = got.unwrap_or_else(|| job.smooth(tol, twice));
        Some((job, done))
    }
}
