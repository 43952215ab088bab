//! The fleet step: every channel against the specification and against its siblings.
//!
//! **Siblings** are the channels of the same sensor kind (gyro or accelerometer) in the run's
//! results with `status = ok`, all axes and files pooled: a fleet of identical parts should have
//! alike axes too, and pooling gives the test enough members in a small fleet.
//!
//! - **Spec verdicts** ([`super::verdict`]) per channel and limit.
//! - **Outliers** per (sensor kind, term): the robust z ([`super::robust`]) of ln(value) among the
//!   siblings with a determined value of that term (its interval stays above 0, and its fit told
//!   it from the neighbouring terms: on a fleet of 256 clean simulated IMUs, R values whose
//!   interval reached 0 or that stood in for K were 24 false outliers at z up to ±28); at least
//!   `min_siblings` of them, else no test. A term
//!   with |z| > `outlier_z` is an outlier, with its z and the fleet median as evidence. The z
//!   divides by the fleet's spread and the estimate's own standard error in quadrature,
//!   z = (ln v − median)/√(s² + u²) (u from the estimate's interval), as ISO 13528 scores a lab
//!   against an assigned value with both uncertainties (its z′/ζ scores): without u, a term that
//!   few channels show and none determines well (a quantisation Q the criterion admitted on 5 of
//!   60 clean channels, ±30 % each) gets a fleet spread from a handful of values that happen to
//!   agree, and a sibling 13 % off reads z = −5.
//! - **Unusual effects** per sensor kind: an effect kind the residual loop added on fewer than
//!   `rare_effect_share` of the analysed siblings (at least `min_siblings` of them) marks each
//!   channel that shows it (a line on one robot of fifty; not the temperature coupling every unit
//!   of the batch shows) — where the channel's evidence for it would stand out among that many
//!   siblings: ΔBIC at or below [`rare_effect_bic`] (the loop's −6 less 2·ln of the siblings,
//!   −17 among 300), as a p-value is divided by the number of tests. The loop's own threshold
//!   is one channel's: on clean simulated fleets it adds a chance effect (a Gaussian-tail
//!   "spike", a step in a random walk) to about 1–2 % of channels, which flagged 10–22 % of
//!   6-axis units as unusual; their ΔBIC was −6.1 to −14.4. A weaker effect stays in the row's
//!   effects, unflagged.
//! - **Quality**: a channel the quality screen gave a verdict other than `no_unit` (stuck,
//!   frozen runs, saturation, too few levels), or an output grid too coarse to read its noise
//!   from (`coarse_output`, from the [`crate::model::FitWarning::OutputResolution`] warning).
//!
//! A channel is *flagged* when it fails a limit, is an outlier in a term, shows an unusual effect
//! or has such a quality verdict; `reasons` says which, with the numbers. Undecided verdicts are
//! listed but do not flag: they say the record cannot tell, not that the sensor is bad.

use std::collections::BTreeMap;

use crate::model::{CoefUnit, Sensor, Term};

use super::record::{ChannelRecord, Status};
use super::robust::RobustScale;
use super::spec::Spec;
use super::table::sensor_name;
use super::verdict::{judge, Basis, Verdict};

/// The ΔBIC an effect few of `siblings` channels show must reach to mark the channel unusual:
/// the loop's [`crate::effects::closing::ADMIT_BIC`] less 2·ln(siblings).
pub fn rare_effect_bic(siblings: usize) -> f64 {
    crate::effects::closing::ADMIT_BIC - 2.0 * (siblings.max(1) as f64).ln()
}

/// One term of one channel, judged.
#[derive(Debug, Clone, Copy, PartialEq, Default)]
pub struct TermAssessment {
    /// The specification's limit (SI), if it sets one.
    pub limit: Option<f64>,
    pub verdict: Option<Verdict>,
    pub basis: Option<Basis>,
    /// Robust z of ln(value) among the siblings (`None`: no value, or too few siblings).
    pub z: Option<f64>,
    /// The siblings' median of the term (SI), the z's reference.
    pub median: Option<f64>,
    pub outlier: bool,
}

/// An effect few siblings show.
#[derive(Debug, Clone, PartialEq)]
pub struct UnusualEffect {
    pub kind: String,
    /// Channels of this sensor kind that show it, and that were analysed.
    pub count: usize,
    pub siblings: usize,
}

/// A channel with its judgement.
#[derive(Debug, Clone, PartialEq)]
pub struct FleetRow {
    pub record: ChannelRecord,
    pub terms: [TermAssessment; 5],
    pub unusual_effects: Vec<UnusualEffect>,
    pub flagged: bool,
    /// One line per reason it is flagged (spec failures, outliers, unusual effects, quality).
    pub reasons: Vec<String>,
}

impl FleetRow {
    /// Whether some term fails its limit (the interval wholly above it).
    pub fn fails_spec(&self) -> bool {
        self.terms.iter().any(|t| t.verdict == Some(Verdict::Fail))
    }
}

/// Which channels make `screen` exit with [`FailOn::EXIT_CODE`] (a nightly job or CI gate reads
/// the exit code, not the table).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub enum FailOn {
    /// A channel that fails a limit of the specification.
    #[default]
    Fail,
    /// Any flagged channel: a limit failure, an outlier, an unusual effect, a quality verdict.
    Flagged,
    /// Never: the exit code says only whether every input was read and analysed.
    Never,
}

impl FailOn {
    /// The exit code of a screen whose inputs were all analysed but some channel matched.
    pub const EXIT_CODE: i32 = 3;

    /// Whether `row` counts.
    pub fn matches(self, row: &FleetRow) -> bool {
        match self {
            FailOn::Fail => row.fails_spec(),
            FailOn::Flagged => row.flagged,
            FailOn::Never => false,
        }
    }
}

impl std::str::FromStr for FailOn {
    type Err = String;
    fn from_str(s: &str) -> Result<Self, String> {
        match s.trim() {
            "fail" => Ok(FailOn::Fail),
            "flagged" => Ok(FailOn::Flagged),
            "never" => Ok(FailOn::Never),
            other => Err(format!("{other:?}: expected fail, flagged or never")),
        }
    }
}

/// The fleet statistics of one term of one sensor kind.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct TermStats {
    pub sensor: Sensor,
    pub term: Term,
    /// ln-scale centre and spread; `None` below `min_siblings`.
    pub scale: Option<RobustScale>,
    /// Channels with a value of the term.
    pub count: usize,
}

/// The judged fleet.
#[derive(Debug, Clone, PartialEq)]
pub struct Fleet {
    pub rows: Vec<FleetRow>,
    pub stats: Vec<TermStats>,
    pub spec: Spec,
}

/// The unit a term is shown in: the limit's when the specification sets one, else the
/// datasheet unit.
pub fn display_unit(spec: &Spec, sensor: Sensor, term: Term) -> CoefUnit {
    spec.limit(sensor, term)
        .map_or_else(|| CoefUnit::display_pair(sensor, term).0, |l| l.unit)
}

/// `value` (SI) in the display unit, with 4 significant digits and the unit.
pub fn show(spec: &Spec, sensor: Sensor, term: Term, value: f64) -> String {
    let u = display_unit(spec, sensor, term);
    format!("{} {}", crate::report::sig4(u.from_si(value)), u.pretty())
}

/// Whether the quality screen doubts what a channel's numbers mean (stuck, frozen for a while,
/// saturated, gravity in another unit, too few levels, an output grid too coarse: any verdict
/// but `no_unit`). Such a channel is flagged for it and is scored against its siblings, but does
/// not shape the fleet's median and spread: a gyro frozen for 60 % of its record, and three
/// accelerometers read in g as m/s² (N at 0.09× the fleet), had joined them.
fn suspect(r: &ChannelRecord) -> bool {
    r.quality.iter().any(|q| q != "no_unit")
}

/// Judges every record. Rows are ordered by relative path, key and channel position, so that the
/// table does not depend on how the run was sharded.
pub fn assess(mut records: Vec<ChannelRecord>, spec: &Spec) -> Fleet {
    records.sort_by(|a, b| {
        (a.rel.as_str(), a.key.as_str(), a.channel_index).cmp(&(
            b.rel.as_str(),
            b.key.as_str(),
            b.channel_index,
        ))
    });
    let opts = spec.fleet;
    let ok = |r: &&ChannelRecord| r.status == Status::Ok;
    let mut stats = Vec::new();
    for sensor in [Sensor::Gyro, Sensor::Accel] {
        for term in Term::ALL {
            let logs: Vec<f64> = records
                .iter()
                .filter(ok)
                .filter(|r| r.kind == Some(sensor) && !suspect(r))
                .map(|r| r.term(term))
                .filter(|t| t.determined())
                .filter_map(|t| t.value)
                .filter(|v| v.is_finite())
                .map(f64::ln)
                .collect();
            // A limited term is shown even where no channel determines it: its verdicts then
            // rest on upper limits, which the fleet page draws against the limit.
            let limited = spec.limit(sensor, term).is_some()
                && records
                    .iter()
                    .filter(ok)
                    .any(|r| r.kind == Some(sensor) && r.term(term).upper.is_some());
            if logs.is_empty() && !limited {
                continue;
            }
            stats.push(TermStats {
                sensor,
                term,
                scale: RobustScale::of(&logs, opts.min_siblings),
                count: logs.len(),
            });
        }
    }
    // Effect counts per sensor kind over the analysed channels.
    let mut effect_counts: BTreeMap<(&'static str, String), usize> = BTreeMap::new();
    let mut analysed: BTreeMap<&'static str, usize> = BTreeMap::new();
    for r in records.iter().filter(ok).filter(|r| r.analysed) {
        let Some(sensor) = r.kind else { continue };
        *analysed.entry(sensor_name(sensor)).or_default() += 1;
        let mut kinds: Vec<&String> = r.effects.iter().collect();
        kinds.sort();
        kinds.dedup();
        for k in kinds {
            *effect_counts
                .entry((sensor_name(sensor), k.clone()))
                .or_default() += 1;
        }
    }
    let copies = same_data(&records);
    let mut rows: Vec<FleetRow> = records
        .into_iter()
        .map(|record| {
            let mut terms = [TermAssessment::default(); 5];
            let mut unusual = Vec::new();
            let mut reasons = Vec::new();
            if let Some(others) = copies.get(record.key.as_str()) {
                reasons.push(format!(
                    "same data as {}: every channel's length and estimates agree to the last \
                     digit, which only the same samples give (a copy under another name hides \
                     a sensor missing from the batch)",
                    others.join(", ")
                ));
            }
            if let (Status::Ok, Some(sensor)) = (record.status, record.kind) {
                for term in Term::ALL {
                    let a = &mut terms[term.index()];
                    let values = record.term(term);
                    if let Some(limit) = spec.limit(sensor, term) {
                        let (v, b) = judge(values.interval(), values.upper, limit.si);
                        a.limit = Some(limit.si);
                        a.verdict = Some(v);
                        a.basis = Some(b);
                        if v == Verdict::Fail {
                            let (lo, hi) = values.interval().unwrap_or((f64::NAN, f64::NAN));
                            reasons.push(format!(
                                "{} fails: {} [{}, {}] > limit {}",
                                term.symbol(),
                                show(spec, sensor, term, values.value.unwrap_or(f64::NAN)),
                                show(spec, sensor, term, lo),
                                show(spec, sensor, term, hi),
                                show(spec, sensor, term, limit.si),
                            ));
                        }
                    }
                    let stat = stats
                        .iter()
                        .find(|s| s.sensor == sensor && s.term == term)
                        .and_then(|s| s.scale);
                    // Only a value the record determines is compared: one whose interval
                    // reaches 0 has no standard error on the log scale, and one its fit could
                    // not tell from a neighbouring term is an attribution (R for K).
                    let determined = values.value.filter(|_| values.determined());
                    let u = values.log_se();
                    if let (Some(s), Some(v), Some(u)) = (stat, determined, u) {
                        let z = s.z_with(v.ln(), u);
                        a.z = Some(z);
                        a.median = Some(s.median.exp());
                        a.outlier = z.abs() > opts.outlier_z;
                        if a.outlier {
                            let ratio = v / s.median.exp();
                            let hint = unit_hint(ratio).map_or(String::new(), |h| format!("; {h}"));
                            reasons.push(format!(
                                "{} outlier: {} is {:.2}× the fleet median {} (robust z = {:+.1}){hint}",
                                term.symbol(),
                                show(spec, sensor, term, v),
                                ratio,
                                show(spec, sensor, term, s.median.exp()),
                                z
                            ));
                        }
                    }
                }
                let name = sensor_name(sensor);
                let siblings = analysed.get(name).copied().unwrap_or(0);
                if record.analysed && siblings >= opts.min_siblings {
                    let mut kinds: Vec<&String> = record.effects.iter().collect();
                    kinds.sort();
                    kinds.dedup();
                    for k in kinds {
                        let count = effect_counts
                            .get(&(name, k.clone()))
                            .copied()
                            .unwrap_or(0);
                        // The strongest evidence for this kind on the channel (records without
                        // the ΔBIC column count as strong).
                        let evidence = record
                            .effects
                            .iter()
                            .zip(record.effects_delta_bic.iter().chain(std::iter::repeat(&f64::NEG_INFINITY)))
                            .filter(|(e, _)| *e == k)
                            .map(|(_, &d)| d)
                            .fold(f64::INFINITY, f64::min);
                        if (count as f64) < opts.rare_effect_share * siblings as f64
                            && evidence <= rare_effect_bic(siblings)
                        {
                            let detail = record
                                .effects
                                .iter()
                                .zip(&record.effects_detail)
                                .find(|(e, _)| *e == k)
                                .map_or(String::new(), |(_, d)| format!(": {d}"));
                            reasons.push(format!(
                                "unusual effect {k} ({count} of {siblings} {name} channels show it){detail}"
                            ));
                            unusual.push(UnusualEffect {
                                kind: k.clone(),
                                count,
                                siblings,
                            });
                        }
                    }
                }
                for (q, d) in record.quality.iter().zip(&record.quality_detail) {
                    if q != "no_unit" {
                        reasons.push(format!("quality {q}: {d}"));
                    }
                }
            }
            FleetRow {
                flagged: !reasons.is_empty(),
                record,
                terms,
                unusual_effects: unusual,
                reasons,
            }
        })
        .collect();
    file_wide_shifts(&mut rows, spec);
    gravity_elsewhere(&mut rows, spec);
    Fleet {
        rows,
        stats,
        spec: spec.clone(),
    }
}

/// Least channels of one input with a z for a term before their combined z is taken.
const FILE_WIDE_MIN_CHANNELS: usize = 3;

/// Every channel of one input shifted alike against the fleet: the z of a term over the input's
/// channels that are not outliers on it by themselves, combined (Stouffer, Σz/√k), beyond the
/// outlier threshold. A 200-Hz recording stamped as 100 Hz reads every axis's N √2 high; among
/// siblings spread 12 % its six axes scored z 0.55–3.65 and one was called an outlier, with
/// nothing said of the file. Those channels get the reason and are flagged.
fn file_wide_shifts(rows: &mut [FleetRow], spec: &Spec) {
    let threshold = spec.fleet.outlier_z;
    let mut by_input: BTreeMap<String, Vec<usize>> = BTreeMap::new();
    for (i, r) in rows.iter().enumerate() {
        if r.record.status == Status::Ok {
            by_input.entry(r.record.key.clone()).or_default().push(i);
        }
    }
    for members in by_input.values() {
        for term in Term::ALL {
            // The channels that are not outliers on the term by themselves: one axis far out
            // (a high-ARW gyro, a mislabelled unit) is that axis's finding, not the file's.
            let scored: Vec<(usize, f64, f64)> = members
                .iter()
                .filter(|&&i| !rows[i].terms[term.index()].outlier)
                .filter_map(|&i| {
                    let a = &rows[i].terms[term.index()];
                    let value = rows[i].record.term(term).value?;
                    Some((i, a.z?, value / a.median?))
                })
                .collect();
            if scored.len() < FILE_WIDE_MIN_CHANNELS {
                continue;
            }
            let combined =
                scored.iter().map(|(_, z, _)| z).sum::<f64>() / (scored.len() as f64).sqrt();
            if combined.abs() <= threshold {
                continue;
            }
            let (lo, hi) = scored
                .iter()
                .fold((f64::INFINITY, 0.0f64), |(lo, hi), &(_, _, r)| {
                    (lo.min(r), hi.max(r))
                });
            let reason = format!(
                "{} {} across the file's {} channels: combined z = {combined:+.1} (each {lo:.2}–{hi:.2}× \
                 its fleet median); every axis shifted alike points at the whole file or unit: a \
                 sample rate or scale wrong for all of it, or a unit worse on every axis",
                term.symbol(),
                if combined > 0.0 { "high" } else { "low" },
                scored.len()
            );
            for (i, _, _) in &scored {
                rows[*i].reasons.push(reason.clone());
                rows[*i].flagged = true;
            }
        }
    }
}

/// Share of standard gravity above which an accelerometer axis "holds gravity" (a tilt of 30°
/// from it keeps 87 %, one of 60° 50 %).
const GRAVITY_SHARE: f64 = 0.5;

/// An accelerometer axis that holds gravity where most siblings of the same name do not, or the
/// other way round: the axes of that input are swapped or its unit was mounted differently, and
/// a verdict against siblings that sit otherwise compares different things (a unit whose x and
/// z columns were swapped had gravity on accel_x at 9.72 m/s² beside 90 siblings at 0.0 and
/// was flagged for nothing). Judged per channel name among at least `min_siblings` analysed
/// siblings, on the majority's side by more than 2:1.
fn gravity_elsewhere(rows: &mut [FleetRow], spec: &Spec) {
    let g = crate::units::STANDARD_GRAVITY;
    let holds = |m: f64| m.abs() > GRAVITY_SHARE * g;
    let mut by_name: BTreeMap<String, (usize, usize)> = BTreeMap::new();
    for r in rows.iter() {
        let rec = &r.record;
        if let (Status::Ok, Some(Sensor::Accel), Some(name), Some(m)) =
            (rec.status, rec.kind, rec.channel.as_ref(), rec.mean)
        {
            let e = by_name.entry(name.clone()).or_default();
            if holds(m) {
                e.0 += 1;
            } else {
                e.1 += 1;
            }
        }
    }
    for r in rows.iter_mut() {
        let rec = &r.record;
        let (Status::Ok, Some(Sensor::Accel), Some(name), Some(m)) =
            (rec.status, rec.kind, rec.channel.as_ref(), rec.mean)
        else {
            continue;
        };
        let Some(&(with, without)) = by_name.get(name) else {
            continue;
        };
        if with + without < spec.fleet.min_siblings {
            continue;
        }
        let reason = if holds(m) && without > 2 * with {
            format!(
                "gravity on {name} ({:.3} m/s²) where {without} of the {} {name} channels have \
                 it on another axis: axes swapped, or the unit mounted differently",
                m,
                with + without
            )
        } else if !holds(m) && with > 2 * without {
            format!(
                "no gravity on {name} ({:.3} m/s²) where {with} of the {} {name} channels have \
                 it: axes swapped, or the unit mounted differently",
                m,
                with + without
            )
        } else {
            continue;
        };
        r.reasons.push(reason);
        r.flagged = true;
    }
}

/// Factors by which a unit mislabel moves every coefficient of a channel, with what they are.
const UNIT_FACTORS: [(f64, &str); 4] = [
    (
        180.0 / std::f64::consts::PI,
        "a degree per radian (deg/s read as rad/s?)",
    ),
    (9.80665, "m/s² per g (g read as m/s²?)"),
    (1000.0, "a thousand (milli- read as the unit?)"),
    (3600.0, "seconds per hour (°/h read as °/s?)"),
];

/// The unit mislabel an outlier's ratio to the fleet median points at: the ratio (or its
/// inverse) within 10 % of one of [`UNIT_FACTORS`].
fn unit_hint(ratio: f64) -> Option<String> {
    let (r, inverse) = if ratio >= 1.0 {
        (ratio, false)
    } else {
        (1.0 / ratio, true)
    };
    UNIT_FACTORS
        .iter()
        .find(|(f, _)| (r / f - 1.0).abs() < 0.1)
        .map(|(f, what)| {
            format!(
                "{}{} is {what}",
                if inverse { "1/" } else { "" },
                crate::report::sig4(*f)
            )
        })
}

/// The inputs whose analysed channels agree with another input's in every channel's name, sample
/// count and every estimate's bits (value and interval of each term): the same samples, read
/// twice (a file copied under another name, or to two folders). Each such input's key maps to
/// the paths of the others. Inputs with no analysed channel are never copies: two files that
/// fail alike say nothing. Different encodings of the same data (CSV text and Arrow floats)
/// round differently and are not found.
fn same_data(records: &[ChannelRecord]) -> BTreeMap<String, Vec<String>> {
    // Per input: each analysed channel's name, sample count and the bits of every estimate.
    type Print<'a> = Vec<(&'a str, Option<u64>, Vec<Option<u64>>)>;
    let mut prints: BTreeMap<&str, (Print<'_>, &str)> = BTreeMap::new();
    for r in records
        .iter()
        .filter(|r| r.status == Status::Ok && r.analysed)
    {
        let bits = r
            .terms
            .iter()
            .flat_map(|t| [t.value, t.lo, t.hi, t.upper])
            .map(|v| v.map(f64::to_bits))
            .collect();
        prints
            .entry(r.key.as_str())
            .or_insert((Vec::new(), &r.rel))
            .0
            .push((r.channel.as_deref().unwrap_or(""), r.samples, bits));
    }
    let mut groups: BTreeMap<&Print<'_>, Vec<(&str, &str)>> = BTreeMap::new();
    for (key, (print, rel)) in &prints {
        groups.entry(print).or_default().push((key, rel));
    }
    let mut out = BTreeMap::new();
    for members in groups.values().filter(|m| m.len() > 1) {
        for (key, _) in members {
            let others = members
                .iter()
                .filter(|(k, _)| k != key)
                .map(|(_, rel)| rel.to_string())
                .collect();
            out.insert(key.to_string(), others);
        }
    }
    out
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::fleet::record::TermValues;
    use crate::fleet::Input;

    fn channel(i: usize, n: f64, effects: &[&str]) -> ChannelRecord {
        let input = Input {
            path: format!("f/s{i:02}.arrow").into(),
            rel: format!("s{i:02}.arrow"),
            sensor: format!("s{i:02}"),
            key: format!("s{i:02}-0"),
            hash: i as u64,
        };
        let mut r = ChannelRecord::error(&input, String::new());
        r.status = Status::Ok;
        r.error = None;
        r.kind = Some(Sensor::Gyro);
        r.channel = Some("gyro_x".into());
        r.channel_index = Some(0);
        r.analysed = true;
        r.terms[Term::RandomWalk.index()] = TermValues {
            value: Some(n),
            lo: Some(n * 0.97),
            hi: Some(n * 1.03),
            upper: None,
            lo_one_sigma: Some(n * 0.97),
            hi_one_sigma: Some(n * 1.03),
            ambiguous: false,
        };
        r.terms[Term::RateRamp.index()].upper = Some(1e-9);
        r.confidence = Some(0.6827);
        r.effects = effects.iter().map(|s| s.to_string()).collect();
        r.effects_detail = effects.iter().map(|s| format!("{s} detail")).collect();
        r.effects_delta_bic = vec![-100.0; effects.len()];
        r
    }

    /// Three axes of one file each 1.15× their siblings (none an outlier alone): the file is
    /// flagged on every axis with the combined z; the others are not.
    #[test]
    fn a_shift_shared_by_every_axis_of_a_file_is_flagged() {
        let n0 = CoefUnit::DegPerSqrtH.to_si(0.15);
        // Deterministic spread of about 5 % in ln N.
        let spread = [
            0.0, 0.8, -0.6, 1.2, -1.1, 0.3, -0.2, 0.9, -0.9, 0.5, -0.4, 1.5, -1.4, 0.1, -0.7,
        ];
        let mut records = Vec::new();
        for (i, g) in spread.iter().enumerate() {
            for axis in 0..3u32 {
                let shift = if i == 0 { 1.15 } else { 1.0 };
                let jitter = 0.05 * (g + 0.3 * (f64::from(axis) - 1.0));
                let mut r = channel(i, n0 * shift * jitter.exp(), &[]);
                r.channel = Some(format!("gyro_{axis}"));
                r.channel_index = Some(axis);
                records.push(r);
            }
        }
        let fleet = assess(records, &Spec::default());
        for row in &fleet.rows {
            let wide = row
                .reasons
                .iter()
                .find(|w| w.contains("across the file's 3 channels"));
            if row.record.key == "s00-0" {
                let w = wide.unwrap_or_else(|| panic!("{row:?}"));
                assert!(w.starts_with("N high") && row.flagged, "{w}");
                assert!(!row.terms[Term::RandomWalk.index()].outlier, "{row:?}");
            } else {
                assert!(wide.is_none() && !row.flagged, "{row:?}");
            }
        }
    }

    #[test]
    fn unit_factors_are_named() {
        assert!(unit_hint(58.38).is_some_and(|h| h.contains("degree")));
        assert!(unit_hint(1.0 / 9.7).is_some_and(|h| h.starts_with("1/9.807")));
        assert!(unit_hint(1050.0).is_some_and(|h| h.contains("thousand")));
        assert!(unit_hint(2.0).is_none() && unit_hint(0.5).is_none() && unit_hint(30.0).is_none());
    }

    /// One unit of twelve with gravity on accel_x instead of accel_z: its two axes are flagged,
    /// nothing else.
    #[test]
    fn gravity_on_another_axis_than_the_siblings_is_flagged() {
        let g = crate::units::STANDARD_GRAVITY;
        let n0 = CoefUnit::DegPerSqrtH.to_si(0.15);
        let mut records = Vec::new();
        for i in 0..12 {
            for (axis, name) in ["accel_x", "accel_y", "accel_z"].iter().enumerate() {
                let mut r = channel(i, n0, &[]);
                r.kind = Some(Sensor::Accel);
                r.channel = Some((*name).into());
                r.channel_index = Some(axis as u32);
                let on_z = if i == 7 { axis == 0 } else { axis == 2 };
                r.mean = Some(if on_z {
                    0.99 * g
                } else {
                    0.02 * (axis as f64 - 1.0)
                });
                records.push(r);
            }
        }
        let fleet = assess(records, &Spec::default());
        let flagged: Vec<(&str, &str)> = fleet
            .rows
            .iter()
            .filter(|r| r.reasons.iter().any(|w| w.contains("mounted differently")))
            .map(|r| {
                (
                    r.record.key.as_str(),
                    r.record.channel.as_deref().unwrap_or(""),
                )
            })
            .collect();
        assert_eq!(
            flagged,
            [("s07-0", "accel_x"), ("s07-0", "accel_z")],
            "{flagged:?}"
        );
    }

    /// A file copied under another name: both copies are flagged, each naming the other; a
    /// sibling that differs in one bit of one estimate, or two inputs that both failed, are not.
    #[test]
    fn copies_of_one_recording_are_flagged() {
        let n0 = CoefUnit::DegPerSqrtH.to_si(0.15);
        let mut records: Vec<ChannelRecord> = (0..8)
            .map(|i| channel(i, n0 * (1.0 + 0.01 * i as f64), &[]))
            .collect();
        let mut copy = channel(3, n0 * 1.03, &[]);
        copy.key = "s03-copy".into();
        copy.rel = "b/s03.arrow".into();
        records.push(copy);
        let mut near = channel(9, n0 * 1.05, &[]);
        near.terms[Term::RandomWalk.index()].hi =
            Some(f64::from_bits((n0 * 1.05 * 1.03).to_bits() + 1));
        records.push(near);
        for i in [10, 11] {
            records.push(ChannelRecord::error(
                &Input {
                    path: "f/bad.arrow".into(),
                    rel: "bad.arrow".into(),
                    sensor: "bad".into(),
                    key: format!("bad-{i}"),
                    hash: 0,
                },
                "file is empty".into(),
            ));
        }
        let fleet = assess(records, &Spec::default());
        let flagged: Vec<(&str, &str)> = fleet
            .rows
            .iter()
            .filter(|r| r.reasons.iter().any(|w| w.starts_with("same data as")))
            .map(|r| (r.record.key.as_str(), r.reasons[0].as_str()))
            .collect();
        assert_eq!(flagged.len(), 2, "{flagged:?}");
        assert!(flagged
            .iter()
            .any(|(k, w)| *k == "s03-0" && w.contains("b/s03.arrow")));
        assert!(flagged
            .iter()
            .any(|(k, w)| *k == "s03-copy" && w.contains("as s03.arrow")));
    }

    /// Channels the quality screen doubts (a frozen run, gravity in another unit) are flagged
    /// for it and scored, but leave the fleet's median and count alone.
    #[test]
    fn quality_suspects_do_not_shape_the_fleet() {
        let n0 = CoefUnit::DegPerSqrtH.to_si(0.15);
        let mut records: Vec<ChannelRecord> = (0..12)
            .map(|i| channel(i, n0 * (1.0 + 0.01 * i as f64), &[]))
            .collect();
        let clean = assess(records.clone(), &Spec::default());
        for (i, q) in [
            (2, "stuck_run"),
            (5, "gravity_scale"),
            (8, "possibly_saturated"),
        ] {
            records[i] = channel(i, 0.1 * n0, &[]);
            records[i].quality = vec![q.into()];
            records[i].quality_detail = vec![format!("{q} detail")];
        }
        let fleet = assess(records, &Spec::default());
        let n = |f: &Fleet| *f.stats.iter().find(|s| s.term == Term::RandomWalk).unwrap();
        assert_eq!(n(&fleet).count, 9);
        let (a, b) = (n(&clean).scale.unwrap(), n(&fleet).scale.unwrap());
        assert!((a.median - b.median).abs() < 0.02, "{a:?} {b:?}");
        for i in [2, 5, 8] {
            let row = &fleet.rows[i];
            assert!(
                row.flagged && row.terms[Term::RandomWalk.index()].outlier,
                "{row:?}"
            );
        }
    }

    #[test]
    fn flags_exactly_the_failure_the_outlier_and_the_rare_effect() {
        let n0 = CoefUnit::DegPerSqrtH.to_si(0.15);
        let mut records: Vec<ChannelRecord> = (0..12)
            .map(|i| channel(i, n0 * (1.0 + 0.02 * (i as f64 - 6.0)), &["coupling"]))
            .collect();
        records[3] = channel(3, 3.0 * n0, &["coupling"]);
        records[7].effects.push("sinusoid".into());
        records[7].effects_detail.push("line at 7 Hz".into());
        records[7].effects_delta_bic.push(-500.0);
        // A rare effect with one channel's evidence (ΔBIC −9), not what stands out among 12
        // (−6 − 2·ln 12 = −11.0): listed, not flagged.
        records[9].effects.push("spikes".into());
        records[9].effects_detail.push("1 spike".into());
        records[9].effects_delta_bic.push(-9.0);
        let spec = Spec::parse("[gyro]\nN = \"0.3 deg/sqrt(h)\"\nR = \"1 deg/h^2\"").unwrap();
        let fleet = assess(records, &spec);
        let flagged: Vec<&str> = fleet
            .rows
            .iter()
            .filter(|r| r.flagged)
            .map(|r| r.record.sensor.as_str())
            .collect();
        assert_eq!(flagged, ["s03", "s07"]);
        let s3 = &fleet.rows[3];
        let n = &s3.terms[Term::RandomWalk.index()];
        assert_eq!(n.verdict, Some(Verdict::Fail));
        assert!(n.outlier && n.z.unwrap() > 3.5, "{n:?}");
        assert!(
            s3.reasons.iter().any(|r| r.contains("N fails")),
            "{:?}",
            s3.reasons
        );
        // R has an upper limit only, below the limit: a pass on that basis.
        let r = &s3.terms[Term::RateRamp.index()];
        assert_eq!(
            (r.verdict, r.basis),
            (Some(Verdict::Pass), Some(Basis::UpperLimit))
        );
        // R has a limit, so the fleet shows it (its upper limits against the limit) though no
        // channel determines it; B, neither limited nor determined anywhere, is not shown.
        let shown: Vec<Term> = fleet.stats.iter().map(|s| s.term).collect();
        assert_eq!(shown, [Term::RandomWalk, Term::RateRamp]);
        let r = fleet
            .stats
            .iter()
            .find(|s| s.term == Term::RateRamp)
            .unwrap();
        assert_eq!((r.count, r.scale), (0, None));
        let s7 = &fleet.rows[7];
        assert_eq!(s7.unusual_effects[0].kind, "sinusoid");
        assert_eq!(s7.unusual_effects[0].count, 1);
        assert!(fleet.rows[9].unusual_effects.is_empty() && !fleet.rows[9].flagged);
        assert!((rare_effect_bic(12) + 10.97).abs() < 0.01);
        // The coupling every channel shows is not unusual.
        assert!(fleet
            .rows
            .iter()
            .all(|r| r.unusual_effects.iter().all(|u| u.kind != "coupling")));
        assert_eq!(
            fleet.rows[0].terms[Term::RandomWalk.index()].verdict,
            Some(Verdict::Pass)
        );
    }

    /// A value the record does not determine is not scored against the siblings: one whose
    /// interval reaches 0 (the rate ramp of a clean 1 h record, 1000× the others, [0, 1.1×]) and
    /// one its fit could not tell from a neighbouring term; the same value with a tight interval
    /// is an outlier. Neither enters the fleet's median. Determined means at 1σ whatever the
    /// run's confidence: a value whose 95 % interval reaches 0 and whose 1σ interval does not is
    /// scored (with the 1σ lower half in its standard error).
    #[test]
    fn undetermined_values_are_not_outliers() {
        let n0 = CoefUnit::DegPerSqrtH.to_si(0.15);
        let mut records: Vec<ChannelRecord> = (0..12)
            .map(|i| channel(i, n0 * (1.0 + 0.02 * (i as f64 - 6.0)), &[]))
            .collect();
        let wild = 1000.0 * n0;
        let tight = TermValues {
            value: Some(wild),
            lo: Some(0.95 * wild),
            hi: Some(1.05 * wild),
            upper: None,
            lo_one_sigma: Some(0.97 * wild),
            hi_one_sigma: Some(1.03 * wild),
            ambiguous: false,
        };
        records[2].terms[Term::RandomWalk.index()] = TermValues {
            lo: Some(0.0),
            hi: Some(1.1 * wild),
            lo_one_sigma: Some(0.0),
            ..tight
        };
        records[7].terms[Term::RandomWalk.index()] = TermValues {
            lo: Some(0.0),
            hi: Some(1.1 * wild),
            ..tight
        };
        records[5].terms[Term::RandomWalk.index()] = TermValues {
            ambiguous: true,
            ..tight
        };
        records[9].terms[Term::RandomWalk.index()] = tight;
        let fleet = assess(records, &Spec::default());
        let n = |i: usize| &fleet.rows[i].terms[Term::RandomWalk.index()];
        assert!(!n(2).outlier && n(2).z.is_none(), "{:?}", n(2));
        assert!(!n(5).outlier && n(5).z.is_none(), "{:?}", n(5));
        assert!(n(9).outlier, "{:?}", n(9));
        assert!(n(7).outlier, "{:?}", n(7));
        let stat = fleet
            .stats
            .iter()
            .find(|s| s.sensor == Sensor::Gyro && s.term == Term::RandomWalk)
            .unwrap();
        assert_eq!(stat.count, 10);
    }

    #[test]
    fn too_few_siblings_no_outlier_test() {
        let records: Vec<ChannelRecord> = (0..4)
            .map(|i| channel(i, 1e-4 * (1.0 + i as f64), &["step"]))
            .collect();
        let fleet = assess(records, &Spec::default());
        assert!(fleet
            .rows
            .iter()
            .all(|r| !r.flagged && r.terms[1].z.is_none()));
    }
}
