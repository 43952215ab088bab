//! Kalibr's `imu.yaml`: the continuous-time noise densities of a camera–IMU calibration, from the
//! fitted model.
//!
//! Kalibr (and OpenVINS, VINS-Fusion, which read the same file) model each axis as white noise
//! plus a random-walk bias and take *continuous-time* densities: `*_noise_density` is N
//! (rad/s/√Hz, m/s²/√Hz) and `*_random_walk` is K (rad/s²/√Hz, m/s³/√Hz); Kalibr itself turns them
//! into discrete-time standard deviations with √rate and 1/√rate. Choices, written into the file:
//! - one value per sensor, the worst (largest) axis, because the file has one number; every axis
//!   is listed in a comment;
//! - the combined value where the term is kept; where it is not, the combined upper limit of
//!   summary.md (the term's home fit's bound, within what the measured Allan curve allows),
//!   marked with its level, rather than 0: a filter told "no bias walk" trusts its bias forever;
//! - every axis's interval in the comments, and beside each key the largest upper end over the
//!   axes (an interval's, or an upper limit): the cautious value. A random walk from a 2-h
//!   record is uncertain by a factor of 1.5–2 (on 13 simulated 2-h records of a 200-Hz MEMS
//!   IMU the gyro key read 0.60–2.1× the truth), and a 1σ upper limit lies below the truth in
//!   one record of six: the key alone ("upper limit", 0.87× the truth) had read as a bound;
//! - ASCII only (the level written "1-sigma"): some YAML readers take the file as Latin-1;
//! - a channel the quality screen flagged (saturated, frozen, gravity in another unit, ...) is
//!   listed with its verdict but is not the worst axis while an unflagged axis of the sensor has
//!   a value: a clipped accelerometer's random walk (26 times the truth) had gone into the file
//!   as the sensor's; where every axis with a value is flagged, the key is written commented out
//!   with the verdict, so that Kalibr stops on the missing key instead of using the value:
//!   accelerometers in m/s² labelled g (every axis flagged `gravity_scale`) had written a noise
//!   density 9.8 times the truth under the comment "worst axis";
//! - no value that is not finite: YAML readers take `inf` as text;
//! - N with the spikes the loop removed where they were the tail of the noise (a `heavy_tail`
//!   warning): a filter sees every sample (Student-t noise: N without them 14 % low);
//! - the bias instability has no place in Kalibr's model; it is listed per axis for reference.

use std::fmt::Write;

use crate::analysis::ChannelAnalysis;
use crate::model::{CoefUnit, FitWarning, Sensor, Term};
use crate::quality::QualityReport;

use super::format::sig;
use super::summary::confidence_text;

/// The value Kalibr gets for `term` of one channel.
#[derive(Debug, Clone, Copy)]
struct AxisValue {
    /// SI.
    value: f64,
    /// The combined interval at the run's confidence (`None` for an upper limit, or a value
    /// without one).
    interval: Option<(f64, f64)>,
    /// The term is not significant: `value` is its upper limit.
    upper: bool,
    domain: &'static str,
}

impl AxisValue {
    /// The largest value the axis allows: its interval's upper end, or its upper limit.
    fn upper_end(&self) -> f64 {
        self.interval
            .map_or(self.value, |(_, hi)| hi.max(self.value))
    }
}

fn value_of(a: &ChannelAnalysis, term: Term) -> Option<AxisValue> {
    // A filter sees every sample: where the spikes removed were the tail of the noise itself
    // (heavy-tailed noise, or glitches reaching down into it), its N is the one with them.
    let with_tail = a.combined.warnings.iter().find_map(|w| match w {
        FitWarning::HeavyTail { n_with, .. } if term == Term::RandomWalk => Some(*n_with),
        _ => None,
    });
    if let Some(n) = with_tail.filter(|n| n.is_finite()) {
        return Some(AxisValue {
            value: n,
            interval: None,
            upper: false,
            domain: "combined, with the heavy tail's spikes",
        });
    }
    if let Some(c) = a.combined.get(term) {
        return Some(AxisValue {
            value: c.value,
            interval: Some((c.lo, c.hi)).filter(|(lo, hi)| lo.is_finite() && hi.is_finite()),
            upper: false,
            domain: "combined",
        });
    }
    a.combined.limit(term).map(|upper| AxisValue {
        value: upper,
        interval: None,
        upper: true,
        domain: "combined",
    })
}

/// `4.3630e-5 [4.3500e-5, 4.3760e-5] rad/s/sqrt(Hz) (combined)`: the value in the SI unit of
/// its term, with its interval.
fn describe(v: Option<AxisValue>, sensor: Sensor, term: Term) -> String {
    match v {
        Some(v) => format!(
            "{}{:.4e}{} {} ({})",
            if v.upper { "< " } else { "" },
            v.value,
            v.interval
                .map_or(String::new(), |(lo, hi)| format!(" [{lo:.4e}, {hi:.4e}]")),
            CoefUnit::si(sensor, term).label(),
            v.domain
        ),
        None => "not available".into(),
    }
}

/// How every `imu.yaml` this program writes begins (an earlier run's folder is recognised by it,
/// [`super::stale`]).
pub const KALIBR_HEADER: &str = "# Kalibr IMU noise model written by imunoise";

/// The file's text for the channels of one recording.
pub fn imu_yaml(
    source: &str,
    rate_hz: f64,
    topic: &str,
    analysis: &[ChannelAnalysis],
    quality: &QualityReport,
) -> String {
    // A quality verdict, or a record in which the sensor moved: its numbers are not its noise.
    let flagged = |channel: &str| {
        quality
            .channels
            .iter()
            .find(|c| c.name == channel)
            .and_then(|c| c.verdicts.first())
            .map(|v| v.describe())
            .or_else(|| {
                analysis
                    .iter()
                    .filter(|a| a.channel == channel)
                    .flat_map(|a| &a.combined.warnings)
                    .find_map(|w| match w {
                        FitWarning::NotStatic { channel, .. } => {
                            Some(format!("not static: {channel} moved"))
                        }
                        _ => None,
                    })
            })
    };
    let mut out = String::new();
    let _ = writeln!(out, "{} {}", KALIBR_HEADER, env!("CARGO_PKG_VERSION"));
    let _ = writeln!(out, "# source: {source}");
    let _ = writeln!(out, "#");
    let _ = writeln!(
        out,
        "# Convention: CONTINUOUS-TIME densities, as Kalibr expects:"
    );
    let _ = writeln!(out, "#   *_noise_density = N (angle/velocity random walk): gyro rad/s/sqrt(Hz), accel m/s^2/sqrt(Hz)");
    let _ = writeln!(out, "#   *_random_walk   = K (rate/acceleration random walk): gyro rad/s^2/sqrt(Hz), accel m/s^3/sqrt(Hz)");
    let _ = writeln!(
        out,
        "#   (the same units as rad/s/sqrt(s) and m/s^2/sqrt(s), which the per-axis comments write)"
    );
    let _ = writeln!(
        out,
        "#   (Kalibr multiplies the density by sqrt(update_rate) and the random walk by"
    );
    let _ = writeln!(
        out,
        "#   1/sqrt(update_rate) to get discrete-time standard deviations.)"
    );
    // ASCII: some YAML readers take the file as Latin-1.
    let level = confidence_text(analysis).replace('σ', "-sigma");
    let _ = writeln!(
        out,
        "# Each value is the worst (largest) axis of the combined estimate (summary.md says"
    );
    let _ = writeln!(
        out,
        "# which fit each comes from). A random walk no fit found significant is given as"
    );
    let _ = writeln!(
        out,
        "# its {level} upper limit (marked '<' below), which the truth exceeds about as"
    );
    let _ = writeln!(
        out,
        "# often as it exceeds an interval's upper end. Intervals are {level}. A random walk"
    );
    let _ = writeln!(
        out,
        "# from a record of a few hours is uncertain by tens of percent or more: where a"
    );
    let _ = writeln!(
        out,
        "# filter must not be over-confident, the largest upper end over the axes (beside"
    );
    let _ = writeln!(
        out,
        "# each key) is the cautious value. Inflate further for your filter as you see fit."
    );
    let mut keys = Vec::new();
    for (sensor, prefix) in [
        (Sensor::Gyro, "gyroscope"),
        (Sensor::Accel, "accelerometer"),
    ] {
        let channels: Vec<&ChannelAnalysis> =
            analysis.iter().filter(|a| a.sensor == sensor).collect();
        let _ = writeln!(out, "#\n# {prefix} axes:");
        if channels.is_empty() {
            let _ = writeln!(out, "#   none in this recording; {prefix}_* keys omitted");
            continue;
        }
        for a in &channels {
            let _ = writeln!(
                out,
                "#   {}: N = {}, K = {}, B = {}{}",
                a.channel,
                describe(value_of(a, Term::RandomWalk), sensor, Term::RandomWalk),
                describe(
                    value_of(a, Term::RateRandomWalk),
                    sensor,
                    Term::RateRandomWalk
                ),
                describe(
                    value_of(a, Term::BiasInstability),
                    sensor,
                    Term::BiasInstability
                ),
                flagged(&a.channel).map_or(String::new(), |v| format!(
                    " [quality: {v}; not taken as the worst axis while another axis has a value]"
                )),
            );
        }
        for (term, key) in [
            (Term::RandomWalk, "noise_density"),
            (Term::RateRandomWalk, "random_walk"),
        ] {
            let axes = |clean: bool| {
                channels
                    .iter()
                    .filter(move |a| !clean || flagged(&a.channel).is_none())
                    .filter_map(|a| value_of(a, term).map(|v| (v, &a.channel)))
                    .filter(|(v, _)| v.value.is_finite())
            };
            let worst = |clean: bool| axes(clean).max_by(|a, b| a.0.value.total_cmp(&b.0.value));
            // The cautious value beside the key: the largest upper end over the same axes.
            let cautious = axes(true)
                .max_by(|a, b| a.0.upper_end().total_cmp(&b.0.upper_end()))
                .map_or(String::new(), |(v, channel)| {
                    format!(
                        "; largest {level} upper end over the axes {:.4e} ({channel})",
                        v.upper_end()
                    )
                });
            match (worst(true), worst(false)) {
                (Some((v, channel)), _) => keys.push(format!(
                    "{prefix}_{key}: {:.6e}  # {} {channel}, {}{}{cautious}",
                    v.value,
                    if v.upper {
                        format!("{level} upper limit,")
                    } else {
                        "worst axis".into()
                    },
                    v.domain,
                    match (v.upper, v.interval) {
                        (true, _) => " (not significant)".into(),
                        (false, Some((lo, hi))) => format!(" [{lo:.4e}, {hi:.4e}]"),
                        (false, None) => String::new(),
                    }
                )),
                (None, Some((v, channel))) => keys.push(format!(
                    "# {prefix}_{key}: {}{:.6e}  # NOT WRITTEN: every {prefix} axis with a \
                     value is flagged by the quality screen ({channel}: {}); fix the input, or \
                     uncomment the key if you accept the value",
                    if v.upper { "< " } else { "" },
                    v.value,
                    flagged(channel).unwrap_or_default()
                )),
                (None, None) => keys.push(format!("# {prefix}_{key}: no fit succeeded")),
            }
        }
    }
    let _ = writeln!(
        out,
        "#\n# update_rate: the recording's sample rate, Hz ({}).",
        sig(rate_hz, 6)
    );
    for k in keys {
        let _ = writeln!(out, "{k}");
    }
    let _ = writeln!(out, "rostopic: {topic}");
    let _ = writeln!(out, "update_rate: {:?}", nominal_rate(rate_hz));
    out
}

/// The rate Kalibr reads, to six significant digits: a rate measured from jittered stamps
/// (199.99999998 over 2 h, 199.999999 over 10 min) is the nominal one within parts per million,
/// far below what the noise densities' √rate conversion can tell.
fn nominal_rate(rate_hz: f64) -> f64 {
    if !(rate_hz.is_finite() && rate_hz > 0.0) {
        return rate_hz;
    }
    let scale = 10f64.powi(6 - rate_hz.log10().ceil() as i32);
    (rate_hz * scale).round() / scale
}

#[cfg(test)]
mod tests {
    use super::nominal_rate;

    #[test]
    fn the_update_rate_has_six_significant_digits() {
        assert_eq!(nominal_rate(199.999999), 200.0);
        assert_eq!(nominal_rate(199.99999998), 200.0);
        assert_eq!(nominal_rate(100.0), 100.0);
        assert_eq!(nominal_rate(207.0), 207.0);
        assert_eq!(nominal_rate(1000.0), 1000.0);
        assert_eq!(nominal_rate(399.98712), 399.987);
        assert_eq!(nominal_rate(1.0001234), 1.00012);
    }
}
