//! The simulator's spindle disturbances changed while it runs (the
//! `ripple` and `noise_rpm` parameters of the simulator node).

use sim_axes::{Spindle, SpindleParams};

#[test]
fn ripple_and_noise_change_while_it_turns_and_bad_values_change_nothing() {
    let dt = 0.001;
    let mut s = Spindle::new(SpindleParams {
        max_rpm: 24_000.0,
        acceleration_rpm_per_s: 1.0e6,
        encoder_counts_per_rev: 4096,
        ripple_fraction: 0.0,
        ripple_hz: 50.0,
        noise_rpm: 0.0,
        seed: 1,
    });
    s.set_command_rpm(1000.0);
    s.step(dt);
    assert_eq!(s.speed_rpm(), 1000.0);
    assert_eq!(
        s.set_disturbances(1.5, 0.0),
        Err("ripple_fraction must be within 0..1")
    );
    assert!(s.set_disturbances(0.0, f64::NAN).is_err());
    assert_eq!(s.params().ripple_fraction, 0.0);
    s.set_disturbances(0.1, 0.0).unwrap();
    let speeds: Vec<f64> = (0..20)
        .map(|_| {
            s.step(dt);
            s.speed_rpm()
        })
        .collect();
    assert!(
        speeds.iter().any(|&v| (v - 1000.0).abs() > 10.0),
        "{speeds:?}"
    );
    assert!(speeds.iter().all(|&v| (v - 1000.0).abs() <= 100.0 + 1e-9));
    s.set_disturbances(0.0, 0.0).unwrap();
    s.step(dt);
    assert_eq!(s.speed_rpm(), 1000.0);
}
