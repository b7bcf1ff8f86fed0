//! The executor: pulls events from the interpreter through the planner and
//! produces one setpoint sample per tick, sample k at t = k·dt exactly.
//! Positions come from the geometry at the profile's path length, never from
//! accumulated increments.
//!
//! Feed hold and abort scale time along the path: a virtual tick counter
//! advances by the feed scale σ per sample instead of 1. σ moves towards its
//! target so that the path speed changes by exactly the move's planned path
//! acceleration per second, so the deceleration stays within the axis
//! limits and the tool stays on the path. With σ = 1 the virtual counter is
//! the tick index and the samples are exactly those of an unscaled run.

use crate::dialect::Dialect;
use crate::interp::{Interpreter, Modal, Src};
use crate::machine::Machine;
use crate::plan::{Item, PlanLimits, PlannedMove, Planner, Timeline};
use crate::source::ProgramSource;
use crate::V3;

/// One interpolation cycle's output.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Sample {
    /// tick index
    pub k: u64,
    /// k·dt, s
    pub t: f64,
    /// commanded position, machine coordinates, mm
    pub pos: V3,
    /// the block being executed
    pub src: Src,
    /// commanded spindle speed, rpm, signed
    pub spindle_rpm: f64,
    pub tool: u32,
    /// path speed commanded at this tick, mm/s
    pub path_speed: f64,
    /// the last sample of the program
    pub last: bool,
}

// one value at a time: boxing the move would only add an allocation
#[allow(clippy::large_enum_variant)]
enum Cur {
    Move(PlannedMove, Option<u64>),
    Dwell(u64),
}

/// Runs a program (which must have passed [`crate::check`]) sample by sample.
pub struct Executor<S> {
    interp: Interpreter<S>,
    planner: Planner,
    timeline: Timeline,
    dt: f64,
    k: u64,
    /// virtual tick: advances by `scale` per sample
    vk: f64,
    /// feed scale σ now, and where it is heading (0 = hold)
    scale: f64,
    target: f64,
    cur: Option<Cur>,
    pos: V3,
    src: Src,
    spindle: f64,
    tool: u32,
    done: bool,
}

impl<S: ProgramSource> Executor<S> {
    pub fn new(source: S, dialect: Dialect, machine: &Machine) -> Self {
        let lim = PlanLimits::from_machine(machine);
        Executor {
            interp: Interpreter::new(source, dialect, machine),
            planner: Planner::new(lim),
            timeline: Timeline::new(lim.dt),
            dt: lim.dt,
            k: 0,
            vk: 0.0,
            scale: 1.0,
            target: 1.0,
            cur: None,
            pos: machine.home(),
            src: Src::default(),
            spindle: 0.0,
            tool: 0,
            done: false,
        }
    }

    /// Interpolation period, s.
    pub fn dt(&self) -> f64 {
        self.dt
    }

    /// The interpreter's modal state (it runs ahead of the samples by the
    /// look-ahead window).
    pub fn modal(&self) -> &Modal {
        &self.interp.modal
    }

    /// Sets the feed scale to head for: 0 holds (decelerating along the
    /// path), 1 runs at the programmed feed. Values are clamped to 0..=1.
    pub fn set_feed_target(&mut self, target: f64) {
        self.target = if target.is_nan() {
            0.0
        } else {
            target.clamp(0.0, 1.0)
        };
    }

    /// The feed scale in force (0 when held still).
    pub fn feed_scale(&self) -> f64 {
        self.scale
    }

    /// Moves σ towards its target: the path speed changes by the move's
    /// path acceleration × dt, measured at the next sample's profile speed.
    fn update_scale(&mut self, m: &PlannedMove, tau: f64) {
        if self.scale == self.target {
            return;
        }
        let vp = m.profile.v_at(tau);
        let v_now = vp * self.scale;
        let step = m.profile.a * self.dt;
        let vp_next = m.profile.v_at(tau + self.scale * self.dt);
        let down = self.target < self.scale;
        let v_next = if down { v_now - step } else { v_now + step };
        let s = if vp_next > 1e-9 {
            v_next / vp_next
        } else {
            self.target
        };
        self.scale = if down {
            s.min(self.scale).max(self.target)
        } else {
            s.max(self.scale).min(self.target)
        };
    }

    /// Errors the interpreter met (none for a checked program).
    pub fn error_count(&self) -> usize {
        self.interp.error_count()
    }

    fn next_item(&mut self) -> Option<Item> {
        loop {
            if let Some(i) = self.planner.pop() {
                return Some(i);
            }
            match self.interp.next() {
                Some(ev) => self.planner.push(ev),
                None => {
                    self.planner.flush();
                    return self.planner.pop();
                }
            }
        }
    }

    fn sample(&self, pos: V3, speed: f64, last: bool) -> Sample {
        Sample {
            k: self.k,
            t: self.k as f64 * self.dt,
            pos,
            src: self.src,
            spindle_rpm: self.spindle,
            tool: self.tool,
            path_speed: speed,
            last,
        }
    }

    /// The next sample, or `None` after the last one.
    pub fn next_sample(&mut self) -> Option<Sample> {
        if self.done {
            return None;
        }
        loop {
            if self.cur.is_none() {
                match self.next_item() {
                    None | Some(Item::End { .. }) => {
                        self.done = true;
                        let s = self.sample(self.pos, 0.0, true);
                        return Some(s);
                    }
                    Some(Item::Move(m)) => {
                        let stop = self.timeline.stop_tick(&m);
                        self.cur = Some(Cur::Move(m, stop));
                    }
                    Some(Item::Dwell { seconds, src }) => {
                        self.scale = self.target;
                        self.src = src;
                        let end = self.timeline.group_k0 + self.timeline.ticks(seconds);
                        self.timeline.finish_dwell(seconds);
                        self.cur = Some(Cur::Dwell(end));
                    }
                    Some(Item::Spindle { rpm, src }) => {
                        self.src = src;
                        self.spindle = rpm;
                    }
                    Some(Item::Tool { number, src }) => {
                        self.src = src;
                        self.tool = number;
                    }
                }
                continue;
            }
            match self.cur {
                Some(Cur::Move(ref m, stop)) => {
                    let m = *m;
                    let tau = self.timeline.local_time(self.vk);
                    let running = match stop {
                        Some(end) => self.vk < end as f64,
                        None => tau < m.profile.duration,
                    };
                    if running {
                        self.src = m.src;
                        let pos = m.geom.eval(m.profile.s_at(tau));
                        let s = self.sample(pos, m.profile.v_at(tau) * self.scale, false);
                        self.update_scale(&m, tau);
                        self.k += 1;
                        self.vk += self.scale;
                        return Some(s);
                    }
                    self.pos = m.geom.end();
                    self.timeline.finish_move(&m);
                    self.cur = None;
                }
                Some(Cur::Dwell(end)) => {
                    if self.vk < end as f64 {
                        let s = self.sample(self.pos, 0.0, false);
                        self.scale = self.target;
                        self.k += 1;
                        self.vk += self.scale;
                        return Some(s);
                    }
                    self.cur = None;
                }
                None => {}
            }
        }
    }
}

impl<S: ProgramSource> Iterator for Executor<S> {
    type Item = Sample;
    fn next(&mut self) -> Option<Sample> {
        self.next_sample()
    }
}
