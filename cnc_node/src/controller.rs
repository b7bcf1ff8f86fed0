//! The controller behind the node: jobs, feed hold, abort, and one sample
//! per interpolation cycle. No DDS, no clocks: the node's loop calls
//! [`Controller::tick`] at its fixed rate, and tests call it directly.

use crate::program::OwnedSource;
use cnc_core::exec::Executor;
use cnc_core::{Dialect, Machine};

/// Controller states, as in `cnc_msgs/ControllerStatus`.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum State {
    Idle = 0,
    Running = 1,
    Hold = 2,
    Error = 3,
}

/// A checked program ready to run.
pub struct Job {
    pub id: u32,
    pub text: Vec<u8>,
    pub dialect: Dialect,
    /// the check's estimate, ticks
    pub ticks: u64,
}

/// What the status topic shows.
#[derive(Clone, Debug, PartialEq)]
pub struct Status {
    pub state: State,
    pub job_id: u32,
    pub source_line: u32,
    pub block_number: i64,
    pub active_g_codes: Vec<String>,
    pub active_tool: i32,
    pub spindle_rpm: f64,
    pub feed_override: f64,
    pub progress: f64,
    pub last_error: String,
}

/// One cycle's output.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Tick {
    /// setpoints in joint order, mm (the first `n` entries)
    pub positions: [f64; 3],
    pub n: usize,
    /// commanded spindle speed, rpm, signed
    pub spindle_rpm: f64,
    pub state: State,
    /// the state or the executing line changed in this cycle
    pub changed: bool,
}

struct Running {
    id: u32,
    exec: Executor<OwnedSource>,
    ticks: u64,
    k: u64,
    aborting: bool,
}

pub struct Controller {
    joints: Vec<usize>,
    machine: Machine,
    state: State,
    job: Option<Running>,
    positions: [f64; 3],
    spindle_rpm: f64,
    tool: u32,
    line: u32,
    block: Option<u64>,
    gcodes: Vec<String>,
    last_job: u32,
    last_error: String,
    progress: f64,
    feed_override: f64,
}

impl Controller {
    pub fn new(machine: Machine) -> Self {
        let joints = machine.joint_indices();
        let home = machine.home();
        let mut positions = [0.0; 3];
        for (j, &i) in joints.iter().enumerate() {
            positions[j] = home[i];
        }
        Controller {
            joints,
            machine,
            state: State::Idle,
            job: None,
            positions,
            spindle_rpm: 0.0,
            tool: 0,
            line: 0,
            block: None,
            gcodes: Vec::new(),
            last_job: 0,
            last_error: String::new(),
            progress: 0.0,
            feed_override: 1.0,
        }
    }

    pub fn machine(&self) -> &Machine {
        &self.machine
    }

    pub fn state(&self) -> State {
        self.state
    }

    /// The running job's id, 0 when idle.
    pub fn job_id(&self) -> u32 {
        self.job.as_ref().map_or(0, |r| r.id)
    }

    /// Starts a checked job; refused while another runs.
    pub fn start(&mut self, job: Job) -> Result<(), String> {
        if let Some(r) = &self.job {
            return Err(format!(
                "job {} is running; wait for its end or abort it (nothing was queued)",
                r.id
            ));
        }
        // a job starts where the machine stands: the program's first move
        // runs from the last setpoint
        let m = self
            .machine
            .starting_at(&self.positions[..self.joints.len()]);
        let exec = Executor::new(OwnedSource::owned(job.text), job.dialect, &m);
        self.job = Some(Running {
            id: job.id,
            exec,
            ticks: job.ticks.max(1),
            k: 0,
            aborting: false,
        });
        self.last_job = job.id;
        self.last_error.clear();
        self.progress = 0.0;
        self.state = State::Running;
        Ok(())
    }

    /// Decelerates along the path, then ends the job.
    pub fn abort(&mut self) -> Result<String, String> {
        match self.job.as_mut() {
            Some(r) => {
                r.aborting = true;
                r.exec.set_feed_target(0.0);
                Ok(format!("job {} stopping", r.id))
            }
            None => Ok("no job running".into()),
        }
    }

    /// `true`: decelerate and hold on the path; `false`: resume.
    pub fn feed_hold(&mut self, on: bool) -> Result<String, String> {
        let ovr = self.feed_override;
        match self.job.as_mut() {
            Some(r) if r.aborting => Err(format!("job {} is being aborted", r.id)),
            Some(r) => {
                r.exec.set_feed_target(if on { 0.0 } else { ovr });
                self.state = if on { State::Hold } else { State::Running };
                Ok(if on { "holding" } else { "resumed" }.into())
            }
            None if on => Err("no job running".into()),
            None => Ok("no job running".into()),
        }
    }

    /// One interpolation cycle.
    pub fn tick(&mut self) -> Tick {
        let before = (self.state, self.line);
        if let Some(r) = self.job.as_mut() {
            match r.exec.next_sample() {
                Some(s) => {
                    for (j, &i) in self.joints.iter().enumerate() {
                        self.positions[j] = s.pos[i];
                    }
                    self.spindle_rpm = s.spindle_rpm;
                    self.tool = s.tool;
                    self.line = s.src.line;
                    self.block = s.src.block_no;
                    r.k += 1;
                    self.progress = (r.k as f64 / r.ticks as f64).min(1.0);
                    let stopped = r.exec.feed_scale() == 0.0;
                    if r.aborting && stopped {
                        self.last_error = format!("job {} aborted at line {}", r.id, s.src.line);
                        self.spindle_rpm = 0.0;
                        self.finish();
                    } else if s.last {
                        self.progress = 1.0;
                        self.finish();
                    } else if self.state == State::Hold && !stopped {
                        // still decelerating into the hold
                    }
                    if let Some(r) = self.job.as_ref() {
                        self.gcodes = r
                            .exec
                            .modal()
                            .gcodes()
                            .iter()
                            .map(|s| s.to_string())
                            .collect();
                    }
                }
                None => self.finish(),
            }
        }
        Tick {
            positions: self.positions,
            n: self.joints.len(),
            spindle_rpm: self.spindle_rpm,
            state: self.state,
            changed: (self.state, self.line) != before,
        }
    }

    fn finish(&mut self) {
        self.job = None;
        self.state = State::Idle;
    }

    /// Ends the job in the error state (lost signal, fault).
    pub fn fail(&mut self, why: String) {
        self.job = None;
        self.state = State::Error;
        self.spindle_rpm = 0.0;
        self.last_error = why;
    }

    pub fn status(&self) -> Status {
        Status {
            state: self.state,
            job_id: self.last_job,
            source_line: self.line,
            block_number: self.block.map_or(-1, |b| b as i64),
            active_g_codes: self.gcodes.clone(),
            active_tool: self.tool as i32,
            spindle_rpm: self.spindle_rpm,
            feed_override: self.feed_override,
            progress: self.progress,
            last_error: self.last_error.clone(),
        }
    }
}
