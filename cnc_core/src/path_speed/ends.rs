//! How a run's braking lands and how it ends: the landing's first jerk
//! (speed and acceleration to zero on the same sample) and the smooth
//! step that puts the last sample exactly on the run's end.

use super::{LAND_MAX, STRETCH_MIN};

/// The first jerk of a landing from `(v, a)`: the jerk, linear in the
/// sample, that brings speed and acceleration to zero together after a
/// whole number of samples, the fewest for which every sample's jerk is
/// within `[lo, hi]` and the speed never goes below zero. `None` if no
/// landing within `LAND_MAX` samples of the shortest conceivable does.
pub(super) fn landing(v: f64, a: f64, lo: f64, hi: f64, dt: f64) -> Option<f64> {
    // the bang-bang stop with the larger jerk: t1 down, then up to zero
    let jm = hi.max(-lo).max(1e-300);
    let t1 = ((a + (a * a / 2.0 + jm * v.max(0.0)).sqrt()) / jm).max(0.0);
    let shortest = (2.0 * t1 - a / jm).max(a.abs() / jm) / dt;
    let first = (shortest.floor() as usize).max(2);
    for n in first..first + LAND_MAX {
        let nf = n as f64;
        // sig_k = al + be * w_k, w_k = n - k - 1/2, k = 0..n-1:
        // sum sig_k dt = -a, and v + n a dt + dt² sum sig_k w_k = 0
        let s1 = -a / dt;
        let s2 = -(v + nf * a * dt) / (dt * dt);
        let (m11, m12, m22) = (nf, nf * nf / 2.0, nf * (4.0 * nf * nf - 1.0) / 12.0);
        let det = m11 * m22 - m12 * m12;
        let al = (s1 * m22 - m12 * s2) / det;
        let be = (m11 * s2 - m12 * s1) / det;
        let ends = [al + be * (nf - 0.5), al + be * 0.5];
        if ends
            .iter()
            .any(|x| *x < lo * (1.0 + 1e-9) - 1e-9 || *x > hi * (1.0 + 1e-9) + 1e-9)
        {
            continue;
        }
        let (mut vv, mut aa) = (v, a);
        let mut ok = true;
        for k in 0..n {
            let sig = al + be * (nf - k as f64 - 0.5);
            vv += aa * dt + sig * dt * dt / 2.0;
            aa += sig * dt;
            if vv < -1e-9 {
                ok = false;
                break;
            }
        }
        if ok {
            return Some(ends[0]);
        }
    }
    None
}

/// Makes the run end exactly on `end`: the little it stops short is added
/// along the last `STRETCH_MIN` samples (all of them if there are fewer),
/// by a quintic smooth step, which starts and ends with no speed and no
/// acceleration of its own.
pub(super) fn stretch(out: &mut [f64], end: f64) {
    let last = out.len() - 1;
    let from = last.saturating_sub(STRETCH_MIN);
    let short = end - out[last];
    let n = (last - from) as f64;
    if n > 0.0 {
        for (k, s) in out[from..].iter_mut().enumerate() {
            let u = k as f64 / n;
            *s += short * u * u * u * (10.0 - 15.0 * u + 6.0 * u * u);
        }
    }
    out[last] = end;
}
