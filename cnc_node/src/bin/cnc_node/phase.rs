//! Where the control cycles stand against the spindle encoder's sampling
//! (the control loop's, `control.rs`): how far after the last
//! sampling instant a cycle runs, and how much later the grid must come
//! for it to run half a period after.

/// Where a cycle stands against the encoder's sampling, as a share of a
/// period: the loop's cycles come this long after the instants the
/// simulator (or drive) samples the spindle at, so that a cycle finds the
/// reading of the instant before it already arrived (its transport on
/// one host takes a few hundred µs) and predicts the spindle angle from a
/// reading of a known age. Left to chance, the two grids stand anywhere
/// against each other, and at a phase under the transport time the loop
/// takes every reading a period late: a G33 setpoint then extrapolates a
/// rippling spindle over a period more.
pub(super) const ENCODER_PHASE: f64 = 0.5;
/// At rest the loop moves its grid when its phase against the readings is
/// further off [`ENCODER_PHASE`] than this share of a period, and has
/// held still to within [`PHASE_STILL`] of a period over [`PHASE_READINGS`]
/// readings in a row (readings not on a grid of the loop's period, as a
/// drive's own timestamps may be, never do).
const PHASE_TOLERANCE: f64 = 0.1;
pub(super) const PHASE_STILL: f64 = 0.02;
pub(super) const PHASE_READINGS: u32 = 5;

/// How much later (ns, under a period) the cycles must come for a cycle
/// at `now_ns` to stand [`ENCODER_PHASE`] of a period after the last
/// sampling instant, given `phase_ns`, where it stands now ([`phase_of`]);
/// None: within [`PHASE_TOLERANCE`].
pub(super) fn phase_delay(phase_ns: i64, period_ns: i64) -> Option<i64> {
    let want = (ENCODER_PHASE * period_ns as f64).round() as i64;
    let off = phase_ns - want;
    let tol = (PHASE_TOLERANCE * period_ns as f64) as i64;
    (off.abs() > tol).then(|| (-off).rem_euclid(period_ns))
}

/// How long after the last sampling instant of the encoder (a reading
/// stamped `reading_ns`, on a grid of `period_ns`) a cycle at `now_ns`
/// stands, ns, under a period.
pub(super) fn phase_of(now_ns: i64, reading_ns: i64, period_ns: i64) -> i64 {
    (now_ns - reading_ns).rem_euclid(period_ns)
}

/// The instant (ns) a cycle stamped `stamp_ns` runs at when it runs
/// `early_ns` before its stamp: where its phase against the readings is
/// taken ([`phase_of`]), since a reading must have arrived by then.
pub(super) fn run_instant(stamp_ns: i64, early_ns: i64) -> i64 {
    stamp_ns - early_ns
}

#[cfg(test)]
mod tests {
    use super::*;

    const MS: i64 = 1_000_000;

    #[test]
    fn cycles_are_moved_to_half_a_period_after_the_sampling() {
        // a cycle 269 us after the reading's instant (as two grids started
        // at random stood in a test run): 231 us later
        let reading = 1_700_000_000_000 * MS + 123_456;
        let now = reading + 7 * MS + 269_000;
        let phase = phase_of(now, reading, MS);
        assert_eq!(phase, 269_000);
        assert_eq!(phase_delay(phase, MS), Some(231_000));
        // 30 us after: 470 us later
        assert_eq!(
            phase_delay(phase_of(reading + 30_000, reading, MS), MS),
            Some(470_000)
        );
        // 900 us after: 600 us later (then 500 us after the next one)
        assert_eq!(phase_delay(900_000, MS), Some(600_000));
        // a reading stamped after the cycle (the clocks' offsets moved)
        assert_eq!(phase_of(reading - 200_000, reading, MS), 800_000);
        // within 100 us of half a period: left as it is
        assert_eq!(phase_delay(400_000, MS), None);
        assert_eq!(phase_delay(600_000, MS), None);
        assert_eq!(phase_delay(399_999, MS), Some(100_001));
        // at 250 Hz: 2 ms after
        assert_eq!(phase_delay(0, 4 * MS), Some(2 * MS));
        // stamped half a period after, but run 150 us before its stamp (a
        // noisy host's margin): 350 us after, so 150 us later
        let run = run_instant(reading + 500_000, 150_000);
        assert_eq!(phase_delay(phase_of(run, reading, MS), MS), Some(150_000));
        // a quiet host's 40 us: within the tolerance
        let run = run_instant(reading + 500_000, 40_000);
        assert_eq!(phase_delay(phase_of(run, reading, MS), MS), None);
    }
}
