//! Numbers and units as a person reads them: in the per-file lines on stderr, `info`, summary.md
//! and the plots. Each number is printed to the precision it has (a rate to 6 significant digits, a
//! count as an integer with its noun in the right number, a throughput to 3 digits with a prefix)
//! and every physical value with its unit. Machine-readable outputs (report.json, the tables) do
//! not come through here: they keep full precision.

use crate::units::{Quantity, Unit};

/// Four significant digits, plain or scientific as fits the magnitude (trailing zeros kept: they
/// say how many digits there are).
pub fn sig4(v: f64) -> String {
    if !v.is_finite() {
        return "–".into();
    }
    if v == 0.0 {
        return "0".into();
    }
    let e = v.abs().log10().floor();
    if (-3.0..5.0).contains(&e) {
        let decimals = (3.0 - e).max(0.0) as usize;
        format!("{v:.decimals$}")
    } else {
        format!("{v:.3e}")
    }
}

/// What a band's edge was read as: "sensor low-pass at 250.0 Hz (order 2)", "sinc³ decimator
/// (CIC) then low-pass at 250.0 Hz (order 2)", "sinc³ decimator (CIC), half power at 266.0 Hz".
pub fn lowpass_text(lp: &crate::model::LowPass) -> String {
    let corner = sig4(lp.corner_hz);
    // "sinc³ decimator (CIC, ↓4)", or without the factor where it is large.
    let decimator = |d: crate::model::Decimator| {
        let k = ["⁰", "¹", "²", "³", "⁴", "⁵"][d.stages as usize];
        match d.factor {
            Some(f) => format!("sinc{k} decimator (CIC, ↓{f})"),
            None => format!("sinc{k} decimator (CIC)"),
        }
    };
    match (lp.decimator, lp.order) {
        (None, order) => format!("sensor low-pass at {corner} Hz (order {order})"),
        (Some(d), 0) => format!("{}, half power at {corner} Hz", decimator(d)),
        (Some(d), order) => format!(
            "{} then low-pass at {corner} Hz (order {order})",
            decimator(d)
        ),
    }
}

/// `digits` significant digits, trailing zeros dropped: 100.00000000002967 → `100`,
/// 207.01234 → `207.012` (6 digits), 0.000123456 → `0.000123456`, 1.5e-7 → `1.5e-7`.
pub fn sig(v: f64, digits: usize) -> String {
    if !v.is_finite() {
        return "–".into();
    }
    if v == 0.0 {
        return "0".into();
    }
    let digits = digits.max(1);
    // Round first, so that 999.9996 at 6 digits reads 1000 and its exponent is the rounded one's.
    let rounded: f64 = format!("{v:.prec$e}", prec = digits - 1)
        .parse()
        .unwrap_or(v);
    let e = rounded.abs().log10().floor() as i32;
    if (-4..7).contains(&e) {
        let decimals = (digits as i32 - 1 - e).max(0) as usize;
        trim_zeros(format!("{rounded:.decimals$}"))
    } else {
        let text = format!("{rounded:.prec$e}", prec = digits - 1);
        match text.split_once('e') {
            Some((mantissa, exp)) => format!("{}e{exp}", trim_zeros(mantissa.to_string())),
            None => text,
        }
    }
}

fn trim_zeros(s: String) -> String {
    if s.contains('.') {
        s.trim_end_matches('0').trim_end_matches('.').to_string()
    } else {
        s
    }
}

/// A sample rate or frequency of a recording: 6 significant digits, `100 Hz`, `207.012 Hz`.
pub fn rate_hz(v: f64) -> String {
    format!("{} Hz", sig(v, 6))
}

/// A count with its noun in the right number: `1 sample`, `2 samples`, `0 gaps`.
pub fn count(n: u64, singular: &str) -> String {
    count_as(n, singular, &format!("{singular}s"))
}

/// [`count`] for a noun whose plural is not the singular plus `s`.
pub fn count_as(n: u64, singular: &str, plural: &str) -> String {
    format!("{n} {}", if n == 1 { singular } else { plural })
}

/// A duration: `12.3 s` below a minute, `900 s (15.0 min)` below two hours, `86400 s (24.0 h)`
/// beyond.
pub fn duration(s: f64) -> String {
    if !s.is_finite() {
        return "–".into();
    }
    if s.abs() < 60.0 {
        format!("{} s", sig(s, 3))
    } else if s.abs() < 7200.0 {
        format!("{s:.0} s ({:.1} min)", s / 60.0)
    } else {
        format!("{s:.0} s ({:.1} h)", s / 3600.0)
    }
}

/// A throughput in `what` per second: an integer below a thousand, else 3 significant digits with
/// a prefix: `512 rows/s`, `4.99 M rows/s`.
pub fn throughput(per_s: f64, what: &str) -> String {
    if !per_s.is_finite() || per_s < 0.0 {
        return format!("– {what}/s");
    }
    let prefixes = [("k", 1e3), ("M", 1e6), ("G", 1e9), ("T", 1e12)];
    // Decide the prefix on the rounded value, so that 999.7 reads `1.00 k` and not `1000`.
    let rounded: f64 = format!("{per_s:.2e}").parse().unwrap_or(per_s);
    if rounded < 1e3 {
        return format!("{per_s:.0} {what}/s");
    }
    let (p, f) = prefixes
        .iter()
        .rev()
        .find(|(_, f)| rounded >= *f)
        .copied()
        .unwrap_or(prefixes[0]);
    let x = per_s / f;
    let decimals = if x >= 100.0 {
        0
    } else if x >= 10.0 {
        1
    } else {
        2
    };
    format!("{x:.decimals$} {p} {what}/s")
}

/// The unit a person reads values of a quantity in, beside SI: °/h for a rate, mg for an
/// acceleration (the datasheet habits); `None` where SI is already that unit.
pub fn engineering_unit(si: Unit) -> Option<Unit> {
    match si.quantity() {
        Quantity::AngularRate => Some(Unit::DegPerH),
        Quantity::Acceleration => Some(Unit::MilliG),
        _ => None,
    }
}

/// `num/den` as a label, parenthesising a numerator that is itself a quotient: `(rad/s)/K`,
/// `mg/°C`.
fn ratio_label(num: &str, den: &str) -> String {
    if num.contains('/') {
        format!("({num})/{den}")
    } else {
        format!("{num}/{den}")
    }
}

/// How a physical value is shown: its SI unit, and an engineering unit beside it where one exists
/// (`0.00203 m/s² (0.207 mg)`). The factor converts the SI value into the second unit.
#[derive(Debug, Clone, PartialEq)]
pub struct Shown {
    si: String,
    other: Option<(String, f64)>,
}

impl Shown {
    /// Values in the SI unit `unit` of a channel (`None`: a channel without a unit, shown as a
    /// plain number).
    pub fn value(unit: Option<Unit>) -> Shown {
        let Some(u) = unit else {
            return Shown {
                si: "(no unit)".into(),
                other: None,
            };
        };
        if u.quantity() == Quantity::Dimensionless {
            // A plain number (counts, a fractional frequency): nothing to write after it.
            return Shown {
                si: String::new(),
                other: None,
            };
        }
        Shown {
            si: u.pretty().into(),
            other: engineering_unit(u).map(|e| (e.pretty().to_string(), 1.0 / e.to_si().0)),
        }
    }

    /// A coefficient of a channel in `num` on another channel (`aux`, in `den`): `(rad/s)/K` and
    /// `(°/h)/°C` for a gyro on a temperature, `(m/s²)/V` and `mg/V` on a voltage, `rad/s per
    /// unit of x` on a channel without a unit.
    pub fn ratio(num: Option<Unit>, den: Option<Unit>, aux: &str) -> Shown {
        let mut value = Shown::value(num);
        if value.si.is_empty() {
            value.si = "1".into();
        }
        let den_labels = match den {
            // A coefficient per degree is the same per kelvin; SI says K, the datasheet °C.
            Some(d) if d.quantity() == Quantity::Temperature => Some(("K", "°C")),
            Some(d) if d.quantity() != Quantity::Dimensionless => Some((d.pretty(), d.pretty())),
            _ => None,
        };
        let Some((den_si, den_other)) = den_labels else {
            let per = |n: &str| format!("{n} per unit of {aux}");
            return Shown {
                si: per(&value.si),
                other: value.other.map(|(l, f)| (per(&l), f)),
            };
        };
        Shown {
            si: ratio_label(&value.si, den_si),
            other: value.other.map(|(l, f)| (ratio_label(&l, den_other), f)),
        }
    }

    /// A value per second squared (the curvature of a drift): `(rad/s)/s²`, `(°/h)/s²`.
    pub fn per_s2(unit: Option<Unit>) -> Shown {
        let value = Shown::value(unit);
        Shown {
            si: ratio_label(&value.si, "s²"),
            other: value.other.map(|(l, f)| (ratio_label(&l, "s²"), f)),
        }
    }

    /// A power (the square of a value): `(rad/s)²`; SI only.
    pub fn squared(unit: Option<Unit>) -> Shown {
        let value = Shown::value(unit);
        Shown {
            si: format!("({})²", value.si),
            other: None,
        }
    }

    /// The SI label.
    pub fn si_label(&self) -> &str {
        &self.si
    }

    /// One value: `0.002030 m/s² (0.2070 mg)`.
    pub fn one(&self, v: f64) -> String {
        self.show(|f| sig4(v * f))
    }

    /// A value with its interval: `0.002030 [0.001981, 0.002079] m/s² (0.2070 [0.2020, 0.2120] mg)`.
    /// An upper end more than [`UNBOUNDED_RATIO`] times the value is `unbounded`: the data set
    /// no upper limit there (a rival Gauss–Markov process's σ of 5.3e-4 m/s² was printed with an
    /// upper end of 3037 m/s², 3·10⁵ mg).
    pub fn interval(&self, v: f64, lo: f64, hi: f64) -> String {
        let unbounded = v > 0.0 && hi > UNBOUNDED_RATIO * v;
        self.show(|f| {
            let top = if unbounded {
                "unbounded".to_string()
            } else {
                sig4(hi * f)
            };
            format!("{} [{}, {top}]", sig4(v * f), sig4(lo * f))
        })
    }

    /// `text(1)` in SI, then `text(factor)` in the other unit: the one layout of every value.
    fn show(&self, text: impl Fn(f64) -> String) -> String {
        match &self.other {
            Some((label, f)) => format!("{} {} ({} {label})", text(1.0), self.si, text(*f)),
            None if self.si.is_empty() => text(1.0),
            None => format!("{} {}", text(1.0), self.si),
        }
    }
}

/// An interval's upper end beyond this many times its value is printed `unbounded`.
pub const UNBOUNDED_RATIO: f64 = 1e3;

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn an_upper_end_a_thousand_times_the_value_is_unbounded() {
        let s = Shown::value(Some(Unit::MPerS2));
        assert_eq!(
            s.interval(5.267e-4, 4.349e-4, 3037.0),
            "5.267e-4 [4.349e-4, unbounded] m/s² (0.05371 [0.04435, unbounded] mg)"
        );
        assert_eq!(
            s.interval(1.0, 0.5, 999.0),
            "1.000 [0.5000, 999.0] m/s² (102.0 [50.99, 1.019e5] mg)"
        );
    }

    #[test]
    fn rates_have_six_significant_digits_and_no_float_noise() {
        assert_eq!(rate_hz(100.000_000_000_029_67), "100 Hz");
        assert_eq!(rate_hz(207.012_345_6), "207.012 Hz");
        assert_eq!(rate_hz(99.999_999_7), "100 Hz");
        assert_eq!(rate_hz(0.5), "0.5 Hz");
        assert_eq!(rate_hz(1_000_000.0), "1000000 Hz");
        assert_eq!(sig(1.5e-7, 6), "1.5e-7");
        assert_eq!(sig(-0.000_123_456_7, 6), "-0.000123457");
    }

    #[test]
    fn counts_agree_with_their_noun() {
        assert_eq!(count(1, "sample"), "1 sample");
        assert_eq!(count(2, "sample"), "2 samples");
        assert_eq!(count(0, "gap"), "0 gaps");
        assert_eq!(count(1, "gap"), "1 gap");
        assert_eq!(count(3, "channel"), "3 channels");
        assert_eq!(count_as(1, "file", "files"), "1 file");
    }

    #[test]
    fn throughput_is_an_integer_or_three_digits_with_a_prefix() {
        assert_eq!(throughput(4_989_290.187_5, "rows"), "4.99 M rows/s");
        assert_eq!(throughput(512.4, "rows"), "512 rows/s");
        assert_eq!(throughput(999.7, "rows"), "1.00 k rows/s");
        assert_eq!(throughput(12_345.0, "rows"), "12.3 k rows/s");
        assert_eq!(throughput(123_456_789.0, "rows"), "123 M rows/s");
        assert_eq!(throughput(0.0, "rows"), "0 rows/s");
    }

    #[test]
    fn durations_read_in_seconds_and_a_larger_unit() {
        assert_eq!(duration(12.345), "12.3 s");
        assert_eq!(duration(0.5), "0.5 s");
        assert_eq!(duration(900.0), "900 s (15.0 min)");
        assert_eq!(duration(1800.0), "1800 s (30.0 min)");
        assert_eq!(duration(86_400.0), "86400 s (24.0 h)");
    }

    #[test]
    fn every_value_carries_the_unit_it_is_in() {
        let accel = Shown::value(Some(Unit::MPerS2));
        assert_eq!(
            accel.interval(0.002_03, 0.001_981, 0.002_079),
            "0.002030 [0.001981, 0.002079] m/s² (0.2070 [0.2020, 0.2120] mg)"
        );
        let gyro = Shown::value(Some(Unit::RadPerS));
        // 1 °/h = π/648000 rad/s.
        assert_eq!(
            gyro.one(std::f64::consts::PI / 648_000.0),
            "4.848e-6 rad/s (1.000 °/h)"
        );
        let coupling = Shown::ratio(Some(Unit::RadPerS), Some(Unit::DegC), "temperature");
        assert_eq!(coupling.si_label(), "(rad/s)/K");
        assert!(
            coupling.one(3.49e-4).ends_with("(°/h)/°C)"),
            "{}",
            coupling.one(3.49e-4)
        );
        let coupling = Shown::ratio(Some(Unit::MPerS2), Some(Unit::DegC), "t");
        assert_eq!(coupling.one(9.80665e-3), "0.009807 (m/s²)/K (1.000 mg/°C)");
        let plain = Shown::ratio(Some(Unit::RadPerS), None, "x");
        assert_eq!(plain.si_label(), "rad/s per unit of x");
        assert_eq!(
            Shown::ratio(Some(Unit::MPerS2), Some(Unit::Volt), "v").si_label(),
            "(m/s²)/V"
        );
        assert_eq!(
            Shown::squared(Some(Unit::RadPerS)).one(2.0),
            "2.000 (rad/s)²"
        );
        assert_eq!(Shown::per_s2(Some(Unit::MPerS2)).si_label(), "(m/s²)/s²");
        // A plain number (a fractional frequency) has nothing after it; per kelvin it is 1/K.
        assert_eq!(
            Shown::value(Some(Unit::One)).interval(1.0, 0.5, 2.0),
            "1.000 [0.5000, 2.000]"
        );
        assert_eq!(
            Shown::ratio(Some(Unit::One), Some(Unit::DegC), "t").si_label(),
            "1/K"
        );
        assert_eq!(Shown::value(None).one(1.0), "1.000 (no unit)");
    }
}
