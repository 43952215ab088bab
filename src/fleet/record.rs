//! One row per inertial channel of a screened file: what the fleet step needs from a file's
//! analysis, and nothing that grows with the recording's length (no spectra, no samples), so that
//! the file's [`FileResult`] can be dropped as soon as its rows are written.
//!
//! A file that could not be analysed (unreadable, empty, no inertial channel, a unit that does not
//! parse) is one row with `status = error` and its message, so that the batch goes on and the
//! fleet table lists it.

use crate::analysis::ChannelAnalysis;
use crate::model::{FitWarning, Sensor, Term};
use crate::pipeline::FileResult;
use crate::report::{effect_lines, EffectUnits};

use super::Input;

/// Whether a file was analysed.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Status {
    Ok,
    Error,
}

impl Status {
    pub fn as_str(self) -> &'static str {
        match self {
            Status::Ok => "ok",
            Status::Error => "error",
        }
    }
}

/// A term's combined estimate with its interval (SI), or, when no fit admitted the term, the
/// upper limit the fits still allow.
#[derive(Debug, Clone, Copy, PartialEq, Default)]
pub struct TermValues {
    pub value: Option<f64>,
    pub lo: Option<f64>,
    pub hi: Option<f64>,
    /// Only when there is no value: the largest coefficient compatible with the data.
    pub upper: Option<f64>,
    /// The interval at 1σ whatever the run's confidence: the comparison with the siblings
    /// (whether the record determines the value, its standard error) is made on it, so that
    /// `--confidence 0.95` widens the verdicts' intervals without moving it (on 546 simulated
    /// channels 95 % intervals reaching 0 took 117 B and K values out of it).
    pub lo_one_sigma: Option<f64>,
    pub hi_one_sigma: Option<f64>,
    /// The fit the value comes from could not tell this term from a neighbour (a K that may be
    /// an R, see [`crate::model::CombinedTerm::ambiguous_with`]): the value is an attribution,
    /// not a measurement of this term, and is not compared with the siblings'.
    pub ambiguous: bool,
}

impl TermValues {
    /// Whether the record determines the value: positive, with a 1σ interval that stays above
    /// 0, and told from the neighbouring terms. Only such values are compared with the siblings'.
    pub fn determined(&self) -> bool {
        self.value.is_some_and(|v| v > 0.0)
            && self.lo_one_sigma.is_some_and(|lo| lo > 0.0)
            && !self.ambiguous
    }

    /// The interval, when the term was estimated.
    pub fn interval(&self) -> Option<(f64, f64)> {
        Some((self.lo?, self.hi?))
    }

    /// The standard error of ln(value) from the 1σ interval: ln(hi/lo)/2; `None` without a
    /// positive value and an interval above 0 (an interval that reaches 0 is unbounded on the log
    /// scale).
    pub fn log_se(&self) -> Option<f64> {
        let (v, lo, hi) = (self.value?, self.lo_one_sigma?, self.hi_one_sigma?);
        (v > 0.0 && lo > 0.0 && hi >= v && lo <= v).then(|| (hi / lo).ln() / 2.0)
    }
}

/// One inertial channel of one file (or the file's error).
#[derive(Debug, Clone, PartialEq)]
pub struct ChannelRecord {
    pub sensor: String,
    /// The path the file was opened at.
    pub path: String,
    /// The path below its input root (see [`super::inputs`]).
    pub rel: String,
    pub key: String,
    pub status: Status,
    pub error: Option<String>,
    /// Where in the file the error is, when it names a place: the column and the 0-based data
    /// row (a CSV header is not a row), as report.json's `error` gives them.
    pub error_column: Option<String>,
    pub error_row: Option<u64>,
    /// Position among the file's channels (all of them, not only the inertial ones).
    pub channel_index: Option<u32>,
    pub channel: Option<String>,
    pub kind: Option<Sensor>,
    pub rate_hz: Option<f64>,
    pub duration_s: Option<f64>,
    pub samples: Option<u64>,
    /// The channel's mean over the record (SI): for an accelerometer, its share of gravity.
    pub mean: Option<f64>,
    /// The noise model was fitted (false for a channel the quality screen found unanalysable, or
    /// whose fits both failed).
    pub analysed: bool,
    /// Per term, in [`Term::ALL`] order.
    pub terms: [TermValues; 5],
    /// Two-sided probability of the intervals (`--confidence`; 0.6827 for 1σ).
    pub confidence: Option<f64>,
    /// Kinds of the effects the residual loop added (`sinusoid`, `step`, …), in the loop's order.
    pub effects: Vec<String>,
    /// The same, described with parameters and intervals.
    pub effects_detail: Vec<String>,
    /// The same, each one's ΔBIC when the loop added it (the fleet step asks more evidence of an
    /// effect that few siblings show: [`super::assess`]).
    pub effects_delta_bic: Vec<f64>,
    /// Names of the quality verdicts (`stuck_run`, `possibly_saturated`, …).
    pub quality: Vec<String>,
    pub quality_detail: Vec<String>,
    /// The combined fit's warnings, the backend's notes and the reader's notes.
    pub warnings: Vec<String>,
}

impl ChannelRecord {
    /// The error row of `input`.
    pub fn error(input: &Input, message: String) -> ChannelRecord {
        ChannelRecord {
            sensor: input.sensor.clone(),
            path: input.path.display().to_string(),
            rel: input.rel.clone(),
            key: input.key.clone(),
            status: Status::Error,
            error: Some(message),
            error_column: None,
            error_row: None,
            channel_index: None,
            channel: None,
            kind: None,
            rate_hz: None,
            duration_s: None,
            samples: None,
            mean: None,
            analysed: false,
            terms: [TermValues::default(); 5],
            confidence: None,
            effects: Vec::new(),
            effects_detail: Vec::new(),
            effects_delta_bic: Vec::new(),
            quality: Vec::new(),
            quality_detail: Vec::new(),
            warnings: Vec::new(),
        }
    }

    /// This error row with the place in the file its error names.
    pub fn at(mut self, column: Option<&str>, row: Option<u64>) -> Self {
        self.error_column = column.map(str::to_owned);
        self.error_row = row;
        self
    }

    /// The values of `term`.
    pub fn term(&self, term: Term) -> &TermValues {
        &self.terms[term.index()]
    }

    /// The rows of a file's result: one per gyro or accelerometer channel, in file order.
    pub fn from_result(input: &Input, r: &FileResult) -> Vec<ChannelRecord> {
        let mut file_notes: Vec<String> = r.recording.notes.clone();
        file_notes.extend(r.backend_notes.iter().cloned());
        file_notes.extend(r.quality.unit_notes());
        r.recording
            .channels
            .iter()
            .enumerate()
            .filter_map(|(i, c)| Some((i, c, Sensor::of_kind(c.kind)?)))
            .map(|(i, c, sensor)| {
                let analysis = r.analysis.iter().flatten().find(|a| a.channel == c.name);
                let quality = r.quality.channels.iter().find(|q| q.name == c.name);
                let mut rec = ChannelRecord::error(input, String::new());
                rec.status = Status::Ok;
                rec.error = None;
                rec.channel_index = Some(i as u32);
                rec.channel = Some(c.name.clone());
                rec.kind = Some(sensor);
                rec.rate_hz = Some(r.recording.rate_hz);
                rec.duration_s = Some(r.quality.duration_s);
                rec.samples = Some(r.quality.samples_out);
                if let Some(q) = quality {
                    rec.mean = Some(q.summary.mean).filter(|m| m.is_finite());
                    for v in &q.verdicts {
                        rec.quality.push(verdict_name(v));
                        rec.quality_detail.push(v.describe());
                    }
                }
                if let Some(a) = analysis {
                    fill_analysis(&mut rec, a, &EffectUnits::of(&r.recording, &c.name));
                }
                rec.warnings.extend(file_notes.iter().cloned());
                rec
            })
            .collect()
    }
}

/// The quality entry of a channel whose output grid hides its noise
/// ([`FitWarning::OutputResolution`] without an upper bound of the sensor's N).
pub const COARSE_OUTPUT: &str = "coarse_output";

fn verdict_name(v: &crate::quality::ChannelVerdict) -> String {
    match serde_json::to_value(v) {
        Ok(serde_json::Value::Object(m)) => m
            .get("verdict")
            .and_then(|s| s.as_str())
            .unwrap_or("unknown")
            .to_string(),
        _ => "unknown".into(),
    }
}

fn fill_analysis(rec: &mut ChannelRecord, a: &ChannelAnalysis, units: &EffectUnits) {
    rec.analysed = a.allan.is_ok() || a.spectrum.is_ok();
    rec.confidence = a.allan_fit().or(a.spectrum_fit()).map(|f| f.confidence);
    for term in Term::ALL {
        let slot = &mut rec.terms[term.index()];
        match a.combined.get(term) {
            Some(c) => {
                slot.value = Some(c.value);
                slot.lo = Some(c.lo);
                slot.hi = Some(c.hi);
                (slot.lo_one_sigma, slot.hi_one_sigma) = (Some(c.one_sigma.0), Some(c.one_sigma.1));
                slot.ambiguous = c.ambiguous_with.is_some();
            }
            None => slot.upper = a.combined.limit(term),
        }
    }
    if let Some(l) = &a.residual_loop {
        let effects: Vec<&crate::effects::Effect> = l.steps.iter().map(|s| &s.effect).collect();
        for (s, line) in l.steps.iter().zip(effect_lines(&effects, units)) {
            rec.effects.push(s.effect.kind().to_string());
            rec.effects_detail.push(line);
            rec.effects_delta_bic.push(s.delta_bic);
        }
    }
    for w in &a.combined.warnings {
        let line = crate::report::warning_line(w, a.sensor);
        // An output too coarse to read the sensor's noise from is a quality matter for a screen,
        // as a channel of one or two levels is (its terms describe the quantiser).
        if let FitWarning::OutputResolution { n_hi: None, .. } = w {
            rec.quality.push(COARSE_OUTPUT.into());
            rec.quality_detail.push(line.clone());
        }
        rec.warnings.push(line);
    }
    for (domain, fit) in [("Allan", &a.allan), ("spectrum", &a.spectrum)] {
        if let Err(e) = fit {
            rec.warnings.push(format!("{domain} fit failed: {e}"));
        }
    }
}
