//! When a fixed-rate loop publishes: every cycle while something happens,
//! at a low rate at rest.

/// When a fixed-rate loop publishes the state it stands in: every cycle
/// while something happens and for [`LINGER_S`] after, at rest only every
/// cycle of a [`REST_RATE_HZ`] grid (cycles n with n % every = 0), so a
/// subscriber that joins late sees where the machine stands within
/// 1 / [`REST_RATE_HZ`], and an idle machine costs little. The controller's
/// setpoints and the simulator's joint states and encoder readings follow
/// it (`docs/ros_interface.md` §3).
#[derive(Clone, Copy, Debug)]
pub struct Pace {
    every: u64,
    linger: u64,
    busy_until: u64,
}

/// The rate of a resting loop's messages, Hz.
pub const REST_RATE_HZ: f64 = 50.0;
/// How long a loop goes on publishing every cycle after the last thing
/// happened, s.
pub const LINGER_S: f64 = 1.0;

impl Pace {
    /// For a loop at `rate_hz`, at rest from its cycle 0.
    pub fn new(rate_hz: f64) -> Self {
        Pace {
            every: ((rate_hz / REST_RATE_HZ).round() as u64).max(1),
            linger: (rate_hz * LINGER_S).ceil() as u64,
            busy_until: 0,
        }
    }

    /// Something happens at cycle `n`: publish every cycle from here until
    /// [`LINGER_S`] after it.
    pub fn busy(&mut self, n: u64) {
        self.busy_until = self.busy_until.max(n.saturating_add(self.linger));
    }

    /// Whether cycle `n` publishes.
    pub fn due(&self, n: u64) -> bool {
        n < self.busy_until || n.is_multiple_of(self.every)
    }

    /// Whether the loop is at rest at cycle `n` (publishing at the low rate).
    pub fn resting(&self, n: u64) -> bool {
        n >= self.busy_until
    }

    /// Cycles between two messages at rest.
    pub fn every(&self) -> u64 {
        self.every
    }

    /// The first cycle from `n` on that publishes: the cycle a loop at rest
    /// can sleep until, running the ones in between at once (they publish
    /// nothing), so it wakes at the resting rate instead of every cycle.
    pub fn next_due(&self, n: u64) -> u64 {
        if n < self.busy_until {
            n
        } else {
            n.div_ceil(self.every) * self.every
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn pace_publishes_every_cycle_while_busy_and_lingers_then_rests() {
        let mut p = Pace::new(1000.0);
        assert_eq!(p.every(), 20);
        // at rest: cycles 0, 20, 40, ...
        let at_rest: Vec<u64> = (0..100).filter(|&n| p.due(n)).collect();
        assert_eq!(at_rest, vec![0, 20, 40, 60, 80]);
        p.busy(105);
        assert!((105..1105).all(|n| p.due(n) && !p.resting(n)));
        assert!(p.resting(1105) && !p.due(1105) && p.due(1120));
        assert_eq!(p.next_due(1000), 1000);
        assert_eq!(p.next_due(1105), 1120);
        assert_eq!(p.next_due(1120), 1120);
        // a slow loop publishes every cycle
        assert_eq!(Pace::new(20.0).every(), 1);
    }
}
