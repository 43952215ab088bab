//! Axis ranges, data-to-pixel transforms and tick generation.

use super::svg::{escape, text_width, trim};
use super::Scale;

/// Relative tolerance for "is this tick inside the range": tick values are computed as
/// `m·10^k` or `i·step` and carry rounding error, and a tick exactly at a range end (the usual
/// case for user-given ranges such as 1e-3..1e2) must not be lost to it.
const EPS: f64 = 1e-9;

/// Whether `v` can be placed on an axis of this scale.
pub(super) fn valid(v: f64, scale: Scale) -> bool {
    v.is_finite() && (scale == Scale::Linear || v > 0.0)
}

/// A data range mapped onto a pixel interval. `p0` is where `lo` lands, `p1` where `hi` lands;
/// for a y axis `p0 > p1` because SVG's y grows downwards.
#[derive(Debug, Clone, Copy, PartialEq)]
pub(super) struct Axis {
    pub scale: Scale,
    pub lo: f64,
    pub hi: f64,
    pub p0: f64,
    pub p1: f64,
}

impl Axis {
    /// Pixel position of `v`. Results are clamped to 10⁵ px around the plot area: points far
    /// outside a user-given range stay finite and short to print, and the clip path hides them;
    /// the angle error this gives a line leaving the area is below 0.01 px.
    pub(super) fn map(&self, v: f64) -> f64 {
        let t = match self.scale {
            Scale::Linear => (v - self.lo) / (self.hi - self.lo),
            Scale::Log => (v.log10() - self.lo.log10()) / (self.hi.log10() - self.lo.log10()),
        };
        let p = self.p0 + t * (self.p1 - self.p0);
        let (a, b) = (self.p0.min(self.p1) - 1e5, self.p0.max(self.p1) + 1e5);
        if p.is_nan() {
            a
        } else {
            p.clamp(a, b)
        }
    }

    pub(super) fn valid(&self, v: f64) -> bool {
        valid(v, self.scale)
    }
}

/// The displayed range: the user's if it is usable on this scale (reversed ends are swapped),
/// else the data extent padded by 5 % of its span (in decades on a log axis) so that markers
/// at the extremes are not cut by the frame. A zero-width extent (all values equal) is widened
/// to a factor of 2 either way (log) or ±10 % (linear) so the ticker still has a span; with no
/// data at all we show 1..10 (log) or 0..1 (linear) around the "no data" note.
pub(super) fn range(
    extent: Option<(f64, f64)>,
    user: Option<(f64, f64)>,
    scale: Scale,
) -> (f64, f64) {
    if let Some((a, b)) = user {
        if valid(a, scale) && valid(b, scale) && a != b {
            return (a.min(b), a.max(b));
        }
    }
    let Some((lo, hi)) = extent else {
        return match scale {
            Scale::Linear => (0.0, 1.0),
            Scale::Log => (1.0, 10.0),
        };
    };
    match scale {
        Scale::Linear => {
            let span = hi - lo;
            if span > 0.0 && span.is_finite() {
                (lo - 0.05 * span, hi + 0.05 * span)
            } else if lo == 0.0 {
                (-1.0, 1.0)
            } else {
                let d = 0.1 * lo.abs();
                (lo - d, hi + d)
            }
        }
        Scale::Log => {
            let span = hi.log10() - lo.log10();
            if span > 0.0 && span.is_finite() {
                let f = 10f64.powf(0.05 * span);
                (lo / f, hi * f)
            } else {
                (lo / 2.0, hi * 2.0)
            }
        }
    }
}

/// A tick label: `mant`, or `mant×10^exp` with the exponent set as a superscript
/// (`10^exp` alone when `mant` is empty). Kept structured until written so that the SVG can
/// use a raised, smaller `<tspan>` instead of unreadable `1e-05` text.
#[derive(Debug, Clone, PartialEq)]
pub(super) struct Label {
    pub mant: String,
    pub exp: Option<i32>,
}

impl Label {
    fn plain(mant: String) -> Label {
        Label { mant, exp: None }
    }

    /// Width in px at font size `size` (the exponent is set at 0.75 `size`).
    pub(super) fn width(&self, size: f64) -> f64 {
        let base = match self.exp {
            None => text_width(&self.mant, size),
            Some(_) if self.mant.is_empty() => text_width("10", size),
            Some(_) => text_width(&self.mant, size) + text_width("×10", size),
        };
        base + self.exp.map_or(0.0, |e| text_width(&sup(e), 0.75 * size))
    }

    /// Inner markup of a `<text>` element. The exponent is raised with `dy` rather than
    /// `baseline-shift`, because `dy` is rendered the same by resvg and all browsers, and it is
    /// the last thing in the element so nothing after it needs lowering back.
    pub(super) fn markup(&self, size: f64) -> String {
        let Some(e) = self.exp else {
            return escape(&self.mant);
        };
        let base = if self.mant.is_empty() {
            "10".to_string()
        } else {
            format!("{}×10", escape(&self.mant))
        };
        format!(
            "{base}<tspan dy=\"{}\" font-size=\"{}\">{}</tspan>",
            super::svg::num(-0.45 * size),
            super::svg::num(0.75 * size),
            sup(e)
        )
    }
}

/// Exponent text with a true minus sign (U+2212), as typeset mathematics uses.
fn sup(e: i32) -> String {
    if e < 0 {
        format!("−{}", e.unsigned_abs())
    } else {
        e.to_string()
    }
}

/// `v` with `decimals` decimals, trailing zeros trimmed, typographic minus.
fn fixed(v: f64, decimals: i32) -> String {
    trim(format!("{:.*}", decimals.clamp(0, 12) as usize, v)).replace('-', "−")
}

/// Label for a single value on a log axis: plain between 10⁻³ and 10⁵, else `m×10^e`.
fn value_label(v: f64) -> Label {
    let e = v.abs().log10().floor() as i32;
    if (-3..=4).contains(&e) {
        return Label::plain(fixed(v, -e + 1));
    }
    let m = v / 10f64.powi(e);
    let mant = fixed(m, 2);
    if mant == "1" {
        Label {
            mant: String::new(),
            exp: Some(e),
        }
    } else {
        Label { mant, exp: Some(e) }
    }
}

/// Major ticks (grid lines are drawn at these), with a label or `None` when labels are thinned;
/// minor ticks are short and unlabelled.
#[derive(Debug, Clone, Default, PartialEq)]
pub(super) struct Ticks {
    pub major: Vec<(f64, Option<Label>)>,
    pub minor: Vec<f64>,
}

impl Ticks {
    pub(super) fn labels(&self) -> impl Iterator<Item = (f64, &Label)> {
        self.major
            .iter()
            .filter_map(|(v, l)| l.as_ref().map(|l| (*v, l)))
    }
}

/// Ticks for `[lo, hi]` with at most about `max_labels` labels.
pub(super) fn ticks(scale: Scale, lo: f64, hi: f64, max_labels: usize) -> Ticks {
    match scale {
        Scale::Linear => linear_ticks(lo, hi, max_labels),
        Scale::Log => log_ticks(lo, hi, max_labels),
    }
}

fn within(v: f64, lo: f64, hi: f64) -> bool {
    let tol = EPS * (hi - lo).abs().max(lo.abs()).max(hi.abs());
    v >= lo - tol && v <= hi + tol
}

/// Log-axis ticks. With two or more decades in range: every decade is a major tick with a grid
/// line, labelled `10^k` (every 2nd, 3rd, 5th… decade when they would not fit), and minor ticks
/// at 2..9 × 10^k while every decade is labelled. With less than two decades, decade labels
/// alone would leave the reader one reference value or none, so we label 1-2-5 × 10^k (minor
/// ticks at the other digits); if even that gives fewer than two, every digit, and for ranges
/// narrower than that, linear nice ticks.
pub(super) fn log_ticks(lo: f64, hi: f64, max_labels: usize) -> Ticks {
    let max_labels = max_labels.max(2);
    let (a, b) = (lo.log10(), hi.log10());
    if !(a.is_finite() && b.is_finite() && b > a) {
        return Ticks::default();
    }
    let (k0, k1) = ((a - EPS).ceil() as i64, (b + EPS).floor() as i64);
    let decade = |k: i64| 10f64.powi(k.clamp(-400, 400) as i32);
    let multiples = |ms: &[f64]| -> Vec<f64> {
        let mut out = Vec::new();
        for k in (a.floor() as i64 - 1)..=(b.ceil() as i64) {
            for m in ms {
                let v = m * decade(k);
                if within(v, lo, hi) {
                    out.push(v);
                }
            }
        }
        out
    };
    if k1 - k0 >= 1 {
        let n = (k1 - k0 + 1) as usize;
        let step = [1usize, 2, 3, 5, 10, 20, 50, 100]
            .into_iter()
            .find(|s| n.div_ceil(*s) <= max_labels)
            .unwrap_or(200) as i64;
        let major = (k0..=k1)
            .map(|k| {
                let label = (k.rem_euclid(step) == 0).then(|| Label {
                    mant: String::new(),
                    exp: Some(k as i32),
                });
                (decade(k), label)
            })
            .collect();
        let minor = if step == 1 {
            multiples(&[2.0, 3.0, 4.0, 5.0, 6.0, 7.0, 8.0, 9.0])
        } else {
            Vec::new()
        };
        return Ticks { major, minor };
    }
    let labelled = |vs: Vec<f64>| vs.into_iter().map(|v| (v, Some(value_label(v)))).collect();
    let t125 = multiples(&[1.0, 2.0, 5.0]);
    if t125.len() >= 2 {
        return Ticks {
            major: labelled(t125),
            minor: multiples(&[3.0, 4.0, 6.0, 7.0, 8.0, 9.0]),
        };
    }
    let t19 = multiples(&[1.0, 2.0, 3.0, 4.0, 5.0, 6.0, 7.0, 8.0, 9.0]);
    if t19.len() >= 2 {
        return Ticks {
            major: labelled(t19),
            minor: Vec::new(),
        };
    }
    linear_ticks(lo, hi, max_labels)
}

/// Linear ticks at the coarsest 1-2-5 × 10^k step giving at most `max_labels` labels, refined
/// (one 1-2-5 step at a time) until at least two ticks fall in range. Labels use as many
/// decimals as the step needs; when the values are ≥ 10⁵ or < 10⁻³ in magnitude each label is
/// in its own scientific notation `m×10^e` (with the digits the step needs), which reads better
/// than a shared exponent with mantissas like `0.2`.
pub(super) fn linear_ticks(lo: f64, hi: f64, max_labels: usize) -> Ticks {
    let span = hi - lo;
    if !(span.is_finite() && span > 0.0) {
        return Ticks::default();
    }
    let n = max_labels.max(2) as f64;
    let mut e = (span / n).log10().floor() as i32;
    // Index into the 1-2-5 ladder: step = [1, 2, 5][idx] · 10^e.
    let mut idx = [1.0, 2.0, 5.0, 10.0]
        .iter()
        .position(|m| span / (m * 10f64.powi(e)) <= n)
        .unwrap_or(3);
    if idx == 3 {
        idx = 0;
        e += 1;
    }
    for _ in 0..4 {
        let m = [1.0, 2.0, 5.0][idx];
        let step = m * 10f64.powi(e);
        let (i0, i1) = ((lo / step - EPS).ceil(), (hi / step + EPS).floor());
        if i1 - i0 >= 1.0 && i1 - i0 < 1000.0 {
            return linear_ticks_at(lo, hi, step, i0 as i64, i1 as i64, e, idx);
        }
        if idx == 0 {
            idx = 2;
            e -= 1;
        } else {
            idx -= 1;
        }
    }
    Ticks::default()
}

fn linear_ticks_at(lo: f64, hi: f64, step: f64, i0: i64, i1: i64, e: i32, idx: usize) -> Ticks {
    let big = lo.abs().max(hi.abs());
    let sci = !(1e-3..1e5).contains(&big);
    let label = |v: f64| {
        if v.abs() < step * 1e-6 {
            Label::plain("0".to_string())
        } else if sci {
            let ve = v.abs().log10().floor() as i32;
            Label {
                mant: fixed(v / 10f64.powi(ve), ve - e),
                exp: Some(ve),
            }
        } else {
            Label::plain(fixed(v, -e))
        }
    };
    let major = (i0..=i1)
        .map(|i| {
            let v = i as f64 * step;
            (v, Some(label(v)))
        })
        .collect();
    let sub = if idx == 1 { 4 } else { 5 };
    let mut minor = Vec::new();
    for i in (i0 - 1)..=i1 {
        for j in 1..sub {
            let v = (i as f64 + j as f64 / sub as f64) * step;
            if within(v, lo, hi) {
                minor.push(v);
            }
        }
    }
    Ticks { major, minor }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn values(t: &Ticks) -> Vec<f64> {
        t.major.iter().map(|(v, _)| *v).collect()
    }
    fn close(a: &[f64], b: &[f64]) -> bool {
        a.len() == b.len()
            && a.iter()
                .zip(b)
                .all(|(x, y)| (x - y).abs() <= 1e-12 * y.abs().max(1e-300))
    }
    fn texts(t: &Ticks) -> Vec<String> {
        t.labels().map(|(_, l)| l.markup(10.0)).collect()
    }

    #[test]
    fn log_ticks_are_the_decades_inside_the_range() {
        let t = log_ticks(3e-4, 2e2, 10);
        assert!(
            close(&values(&t), &[1e-3, 1e-2, 1e-1, 1.0, 1e1, 1e2]),
            "{:?}",
            values(&t)
        );
        assert_eq!(t.labels().count(), 6);
        let l = &t.major[0].1;
        assert_eq!(
            l.as_ref().map(|l| (l.mant.as_str(), l.exp)),
            Some(("", Some(-3)))
        );
        assert!(texts(&t)[0].contains("<tspan dy=\"-4.5\" font-size=\"7.5\">−3</tspan>"));
        // minor ticks at 2..9 × 10^k: 3e-4..9e-4 (7), five full decades (40), 2e2 (1)
        assert_eq!(t.minor.len(), 7 + 40 + 1);
        assert!(t.minor.iter().all(|&v| (3e-4..=2e2).contains(&v)));
    }

    #[test]
    fn log_ticks_include_exact_range_ends() {
        let t = log_ticks(1e-3, 1e2, 10);
        assert!(close(&values(&t), &[1e-3, 1e-2, 1e-1, 1.0, 1e1, 1e2]));
    }

    #[test]
    fn log_ticks_thin_labels_but_keep_decade_ticks() {
        let t = log_ticks(1e-10, 1e10, 6);
        assert_eq!(t.major.len(), 21);
        let labelled: Vec<i32> = t.labels().filter_map(|(_, l)| l.exp).collect();
        assert!(labelled.len() <= 6 && labelled.len() >= 2, "{labelled:?}");
        assert!(labelled
            .windows(2)
            .all(|w| w[1] - w[0] == labelled[1] - labelled[0]));
        assert!(t.minor.is_empty());
    }

    #[test]
    fn narrow_log_range_falls_back_to_1_2_5() {
        let t = log_ticks(2.0, 7.0, 10);
        assert!(close(&values(&t), &[2.0, 5.0]), "{:?}", values(&t));
        assert_eq!(texts(&t), vec!["2", "5"]);
        assert!(close(&t.minor, &[3.0, 4.0, 6.0, 7.0]), "{:?}", t.minor);
        // one decade boundary inside: still 1-2-5 (10 alone would be a single label)
        let t = log_ticks(3.0, 40.0, 10);
        assert!(close(&values(&t), &[5.0, 10.0, 20.0]));
        // no 1-2-5 value inside: every digit
        let t = log_ticks(2.1, 4.9, 10);
        assert!(close(&values(&t), &[3.0, 4.0]));
        // narrower still: linear nice ticks
        let t = log_ticks(2.01, 2.09, 10);
        assert!(t.major.len() >= 2);
        assert!(t.major.iter().all(|(v, _)| (2.01..=2.09).contains(v)));
        // small values get ×10^e labels
        let t = log_ticks(1.5e-6, 8e-6, 10);
        assert_eq!(
            texts(&t)[0],
            "2×10<tspan dy=\"-4.5\" font-size=\"7.5\">−6</tspan>"
        );
    }

    #[test]
    fn log_ticks_never_fewer_than_two_labels() {
        for &(lo, hi) in &[
            (1.0, 1.2),
            (9.0, 11.0),
            (0.5, 2.0),
            (1e-9, 3e-9),
            (123.0, 130.0),
        ] {
            let t = log_ticks(lo, hi, 8);
            assert!(t.labels().count() >= 2, "[{lo}, {hi}]: {:?}", values(&t));
        }
    }

    #[test]
    fn linear_ticks_are_nice() {
        let t = linear_ticks(0.0, 10.0, 6);
        assert!(close(&values(&t), &[0.0, 2.0, 4.0, 6.0, 8.0, 10.0]));
        let t = linear_ticks(-3.2, 3.7, 8);
        assert!(close(&values(&t), &[-3.0, -2.0, -1.0, 0.0, 1.0, 2.0, 3.0]));
        assert_eq!(texts(&t)[0], "−3");
        assert_eq!(texts(&t)[3], "0");
        let t = linear_ticks(0.013, 0.046, 5);
        assert!(close(&values(&t), &[0.02, 0.03, 0.04]), "{:?}", values(&t));
        assert_eq!(texts(&t), vec!["0.02", "0.03", "0.04"]);
        let t = linear_ticks(0.0, 1.0, 3);
        assert!(close(&values(&t), &[0.0, 0.5, 1.0]));
        // few labels allowed and an awkward range: still two ticks
        let t = linear_ticks(0.1, 0.9, 2);
        assert!(t.major.len() >= 2, "{:?}", values(&t));
        let t = linear_ticks(0.0, 3e-6, 4);
        assert_eq!(
            texts(&t)[1],
            "1×10<tspan dy=\"-4.5\" font-size=\"7.5\">−6</tspan>"
        );
        let t = linear_ticks(0.0, 2.1e5, 6);
        let t: Vec<String> = texts(&t)
            .iter()
            .map(|s| {
                s.replace("<tspan dy=\"-4.5\" font-size=\"7.5\">", "^")
                    .replace("</tspan>", "")
            })
            .collect();
        assert_eq!(t, ["0", "5×10^4", "1×10^5", "1.5×10^5", "2×10^5"]);
        assert!(linear_ticks(1.0, 1.0, 5).major.is_empty());
        assert!(linear_ticks(f64::NAN, 1.0, 5).major.is_empty());
    }

    #[test]
    fn transform_maps_range_ends_to_plot_edges() {
        let x = Axis {
            scale: Scale::Log,
            lo: 1e-3,
            hi: 1e2,
            p0: 50.0,
            p1: 550.0,
        };
        assert!((x.map(1e-3) - 50.0).abs() < 1e-9);
        assert!((x.map(1e2) - 550.0).abs() < 1e-9);
        assert!((x.map(1.0) - 350.0).abs() < 1e-9);
        let y = Axis {
            scale: Scale::Linear,
            lo: -2.0,
            hi: 2.0,
            p0: 400.0,
            p1: 100.0,
        };
        assert!((y.map(-2.0) - 400.0).abs() < 1e-9);
        assert!((y.map(2.0) - 100.0).abs() < 1e-9);
        assert!((y.map(0.0) - 250.0).abs() < 1e-9);
        assert_eq!(y.map(1e300), 100.0 - 1e5);
        assert!(x.map(0.0).is_finite() && x.map(f64::NAN).is_finite());
    }

    #[test]
    fn ranges_pad_and_handle_degenerate_extents() {
        let (lo, hi) = range(Some((1e-2, 1e2)), None, Scale::Log);
        assert!(lo < 1e-2 && lo > 5e-3 && hi > 1e2 && hi < 2e2);
        assert_eq!(range(Some((3.0, 3.0)), None, Scale::Log), (1.5, 6.0));
        let (lo, hi) = range(Some((5.0, 5.0)), None, Scale::Linear);
        assert!(lo < 5.0 && hi > 5.0);
        assert_eq!(range(Some((0.0, 0.0)), None, Scale::Linear), (-1.0, 1.0));
        assert_eq!(range(None, None, Scale::Log), (1.0, 10.0));
        assert_eq!(
            range(Some((1.0, 2.0)), Some((10.0, 0.1)), Scale::Log),
            (0.1, 10.0)
        );
        // unusable user range on a log axis: fall back to data
        assert_eq!(
            range(Some((3.0, 3.0)), Some((-1.0, 10.0)), Scale::Log),
            (1.5, 6.0)
        );
    }
}
