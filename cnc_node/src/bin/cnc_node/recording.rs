//! The recorder thread (in [`super`]): a job's recording is written here,
//! off the DDS thread. Writing a recording compresses a chunk every
//! second (zstd) and closes the file with its summary at the job's end;
//! on the DDS thread each of those held up the setpoints behind it by
//! several ms, past the simulator's setpoint delay (3 ms: it counted 1-3
//! late setpoints about every other second of a recorded job, and 19 at
//! its end). The DDS thread now only hands the messages over (an
//! unbounded queue: it never waits, and every message is kept), in batches
//! of [`BATCH_PERIOD`] (a message at a time woke this thread about 3,000
//! times a second while a job ran, and the DDS thread paid for each
//! wake-up); this thread runs at normal priority.

use super::{finish_recording, Rec};
use cnc_msgs::ros;
use cnc_msgs::{ControllerStatus, Float64, JointState, SpindleEncoder};
use std::sync::mpsc::{self, Sender};
use std::thread::JoinHandle;
use std::time::{Duration, Instant};

/// The messages of a recorded job go to the recorder thread together,
/// once this long after the first of them (and at the job's end at once).
const BATCH_PERIOD: Duration = Duration::from_millis(20);

/// What the DDS thread hands the recorder thread, in the order it saw it.
pub(super) enum Msg {
    /// a job's recording starts (its id, the recorder)
    Start(u32, Rec),
    Setpoints(JointState),
    /// the spindle command and its stamp, ns
    Spindle(u64, Float64),
    Status(ControllerStatus),
    Encoder(SpindleEncoder),
    Joints(JointState),
    /// the job's recording ends (the last message before was its last)
    Finish,
}

/// Writes a message into the open recording; an error ends it (a failed
/// encoder or joint state write loses that message only, as it did on the
/// DDS thread).
fn write(rec: &mut Rec, m: Msg) -> Result<(), String> {
    match m {
        Msg::Setpoints(js) => rec.setpoints(&js),
        Msg::Spindle(ns, f) => rec.spindle(ns, &f),
        Msg::Status(s) => rec.status(&s),
        Msg::Encoder(e) => {
            let _ = rec.encoder(&e);
            Ok(())
        }
        Msg::Joints(j) => {
            let _ = rec.joint_states(&j);
            Ok(())
        }
        // (the thread opens and closes the recording itself)
        Msg::Start(..) | Msg::Finish => Ok(()),
    }
}

/// Closes the recording open, if any (`err`: it failed with that).
fn close(open: &mut Option<(u32, Rec)>, err: Option<String>) {
    if let Some((id, rec)) = open.take() {
        finish_recording(id, rec, err);
    }
}

/// The recorder thread and the queue to it.
pub(super) struct Recording {
    tx: Option<Sender<Vec<Msg>>>,
    thread: Option<JoinHandle<()>>,
    /// the job being recorded
    job: Option<u32>,
    /// messages not handed over yet, and when the first of them came
    batch: Vec<Msg>,
    since: Instant,
}

impl Recording {
    /// Starts the thread (at normal priority: `lower` when the DDS threads
    /// run under SCHED_FIFO).
    pub(super) fn start(lower: bool) -> Result<Recording, String> {
        let (tx, rx) = mpsc::channel::<Vec<Msg>>();
        let thread = std::thread::Builder::new()
            .name("recorder".into())
            .spawn(move || {
                if lower {
                    let _ = ros::set_normal();
                }
                let mut open: Option<(u32, Rec)> = None;
                for m in rx.into_iter().flatten() {
                    let r = match m {
                        Msg::Start(id, rec) => {
                            close(&mut open, None);
                            open = Some((id, rec));
                            Ok(())
                        }
                        Msg::Finish => {
                            close(&mut open, None);
                            Ok(())
                        }
                        m => open.as_mut().map_or(Ok(()), |(_, rec)| write(rec, m)),
                    };
                    if let Err(e) = r {
                        close(&mut open, Some(e));
                    }
                }
                // the node ends: the recording open is closed
                close(&mut open, None);
            })
            .map_err(|e| e.to_string())?;
        Ok(Recording {
            tx: Some(tx),
            thread: Some(thread),
            job: None,
            batch: Vec::new(),
            since: Instant::now(),
        })
    }

    /// The job being recorded, if any.
    pub(super) fn job(&self) -> Option<u32> {
        self.job
    }

    /// Hands `m` over when a job is being recorded (a `Start` always): with
    /// the batch, which goes at once at the job's end (`Finish`), else by
    /// [`Recording::flush_due`].
    pub(super) fn send(&mut self, m: Msg) {
        let end = match &m {
            Msg::Start(id, _) => {
                self.job = Some(*id);
                false
            }
            Msg::Finish => {
                self.job = None;
                true
            }
            _ if self.job.is_none() => return,
            _ => false,
        };
        if self.batch.is_empty() {
            self.since = Instant::now();
        }
        self.batch.push(m);
        if end {
            self.flush();
        }
    }

    /// Hands the batch over if its first message came [`BATCH_PERIOD`]
    /// ago or longer (the DDS thread asks at each of its turns).
    pub(super) fn flush_due(&mut self) {
        if !self.batch.is_empty() && self.since.elapsed() >= BATCH_PERIOD {
            self.flush();
        }
    }

    fn flush(&mut self) {
        let batch = std::mem::take(&mut self.batch);
        if let (Some(tx), false) = (&self.tx, batch.is_empty()) {
            let _ = tx.send(batch);
        }
    }

    /// Closes the recording open (if any) and waits until the thread has
    /// written everything handed over.
    pub(super) fn close(&mut self) {
        self.flush();
        self.job = None;
        self.tx = None;
        if let Some(t) = self.thread.take() {
            let _ = t.join();
        }
    }
}

impl Drop for Recording {
    /// (the node ends on an error: what was handed over is written)
    fn drop(&mut self) {
        self.flush();
    }
}
