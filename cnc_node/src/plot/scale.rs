//! Axis ranges and ticks: padding, equal aspect, tick labels, and lines
//! cut at a fixed range's edges.

use super::figure::Point;

/// `(lo, hi)` widened by 4 % and to a non-zero span.
pub(crate) fn pad(lo: f64, hi: f64) -> (f64, f64) {
    let span = hi - lo;
    if span <= 1e-9 * lo.abs().max(hi.abs()).max(1.0) {
        let d = (lo.abs() * 0.05).max(1.0);
        (lo - d, hi + d)
    } else {
        (lo - 0.04 * span, hi + 0.04 * span)
    }
}

/// Widens the ranges so that one unit has the same length in pixels on
/// both axes of a `w` x `h` plotting area.
pub(crate) fn equalize(x: (f64, f64), y: (f64, f64), w: u32, h: u32) -> ((f64, f64), (f64, f64)) {
    let (w, h) = (w.max(1) as f64, h.max(1) as f64);
    let scale = ((x.1 - x.0) / w).max((y.1 - y.0) / h); // units per pixel
    let grow = |r: (f64, f64), px: f64| {
        let c = 0.5 * (r.0 + r.1);
        let half = 0.5 * scale * px;
        (c - half, c + half)
    };
    (grow(x, w), grow(y, h))
}

/// A tick label: no trailing zeros, no `-0`.
pub(crate) fn tick(v: f64) -> String {
    let r = (v * 1000.0).round() / 1000.0;
    let r = if r == 0.0 { 0.0 } else { r };
    let s = format!("{r:.3}");
    let s = s.trim_end_matches('0').trim_end_matches('.');
    s.to_string()
}

/// The parts of a polyline inside the rectangle `xr` × `yr` (segments cut
/// at its edges, Liang–Barsky); points that are not finite break the line.
pub(crate) fn clip_polyline(line: &[Point], xr: (f64, f64), yr: (f64, f64)) -> Vec<Vec<Point>> {
    let inside = |p: Point| p.0 >= xr.0 && p.0 <= xr.1 && p.1 >= yr.0 && p.1 <= yr.1;
    let mut out: Vec<Vec<Point>> = Vec::new();
    let mut cur: Vec<Point> = Vec::new();
    let finite = |p: &Point| p.0.is_finite() && p.1.is_finite();
    let mut prev: Option<Point> = None;
    for &p in line {
        if !finite(&p) {
            prev = None;
            out.extend((!cur.is_empty()).then(|| std::mem::take(&mut cur)));
            continue;
        }
        let Some(a) = prev.replace(p) else {
            if inside(p) {
                cur.push(p);
            }
            continue;
        };
        // the segment a→p as a + t (p − a), t in [t0, t1]
        let (dx, dy) = (p.0 - a.0, p.1 - a.1);
        let (mut t0, mut t1) = (0.0f64, 1.0f64);
        let mut visible = true;
        for (q, r) in [
            (-dx, a.0 - xr.0),
            (dx, xr.1 - a.0),
            (-dy, a.1 - yr.0),
            (dy, yr.1 - a.1),
        ] {
            if q == 0.0 {
                if r < 0.0 {
                    visible = false;
                }
            } else {
                let t = r / q;
                if q < 0.0 {
                    t0 = t0.max(t);
                } else {
                    t1 = t1.min(t);
                }
            }
        }
        if !visible || t0 > t1 {
            out.extend((!cur.is_empty()).then(|| std::mem::take(&mut cur)));
            continue;
        }
        let at = |t: f64| (a.0 + t * dx, a.1 + t * dy);
        if t0 > 0.0 || cur.is_empty() {
            out.extend((!cur.is_empty()).then(|| std::mem::take(&mut cur)));
            cur.push(at(t0));
        }
        cur.push(if t1 < 1.0 { at(t1) } else { p });
        if t1 < 1.0 {
            out.push(std::mem::take(&mut cur));
        }
    }
    out.extend((!cur.is_empty()).then_some(cur));
    out
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn equal_aspect_ranges() {
        let (x, y) = equalize((0.0, 100.0), (0.0, 10.0), 1000, 500);
        assert!(((x.1 - x.0) / 1000.0 - (y.1 - y.0) / 500.0).abs() < 1e-12);
        assert!(x.1 - x.0 >= 100.0 && y.1 - y.0 >= 10.0);
    }

    #[test]
    fn clipping_cuts_lines_at_the_edges() {
        let r = ((0.0, 10.0), (-1.0, 1.0));
        // inside: unchanged
        let l = vec![(0.0, 0.0), (5.0, 0.5), (10.0, -1.0)];
        assert_eq!(clip_polyline(&l, r.0, r.1), vec![l.clone()]);
        // out at the top and back in: two pieces, cut at y = 1
        let l = vec![(0.0, 0.0), (2.0, 2.0), (4.0, 0.0)];
        assert_eq!(
            clip_polyline(&l, r.0, r.1),
            vec![vec![(0.0, 0.0), (1.0, 1.0)], vec![(3.0, 1.0), (4.0, 0.0)]]
        );
        // starts outside, a segment wholly outside, NaN breaks the line
        let l = vec![
            (1.0, -3.0),
            (1.0, 0.0),
            (2.0, 0.0),
            (f64::NAN, 0.0),
            (3.0, 0.0),
            (3.0, 5.0),
            (4.0, 5.0),
        ];
        assert_eq!(
            clip_polyline(&l, r.0, r.1),
            vec![
                vec![(1.0, -1.0), (1.0, 0.0), (2.0, 0.0)],
                vec![(3.0, 0.0), (3.0, 1.0)]
            ]
        );
    }

    #[test]
    fn ticks() {
        assert_eq!(tick(10.0), "10");
        assert_eq!(tick(-0.0001), "0");
        assert_eq!(tick(2.5), "2.5");
    }
}
