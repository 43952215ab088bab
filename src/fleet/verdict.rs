//! A specification limit against what the fits say about a coefficient.
//!
//! The rule, per channel and limit L (an upper limit: noise must not exceed it):
//! - an estimate with interval [lo, hi]: **pass** when hi ≤ L (the whole interval is within
//!   spec), **fail** when lo > L (the whole interval is out), **undecided** when the interval
//!   straddles L: the recording is too short or too disturbed to tell, and saying "pass" on the
//!   value alone would be a coin toss that reads like a measurement;
//! - no estimate, but an upper limit U (the fits did not admit the term; U is what the data still
//!   allow): **pass** when U ≤ L, else **undecided** (the term may be absent, or may be up to U);
//! - neither: **no estimate** (the channel was not analysed, or no fit bounds the term).
//!
//! The intervals are the combined ones ([`crate::model::combine`]) at the run's `--confidence`
//! (1σ by default: a pass then means the value is within spec at about 84 % one-sided).

use serde::Serialize;

/// The outcome of one limit on one channel.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize)]
#[serde(rename_all = "snake_case")]
pub enum Verdict {
    Pass,
    Fail,
    Undecided,
    NoEstimate,
}

impl Verdict {
    pub fn as_str(self) -> &'static str {
        match self {
            Verdict::Pass => "pass",
            Verdict::Fail => "fail",
            Verdict::Undecided => "undecided",
            Verdict::NoEstimate => "no_estimate",
        }
    }
}

/// What the verdict rests on.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize)]
#[serde(rename_all = "snake_case")]
pub enum Basis {
    /// The estimate's interval.
    Interval,
    /// Only an upper limit (the term was not estimated).
    UpperLimit,
    /// Nothing.
    None,
}

impl Basis {
    pub fn as_str(self) -> &'static str {
        match self {
            Basis::Interval => "interval",
            Basis::UpperLimit => "upper_limit",
            Basis::None => "none",
        }
    }
}

/// Judges `limit` (SI) against an estimate's interval `(lo, hi)` or, failing one, an `upper`
/// limit (see the module docs for the rule).
pub fn judge(interval: Option<(f64, f64)>, upper: Option<f64>, limit: f64) -> (Verdict, Basis) {
    match (interval, upper) {
        (Some((lo, hi)), _) => {
            let v = if hi <= limit {
                Verdict::Pass
            } else if lo > limit {
                Verdict::Fail
            } else {
                Verdict::Undecided
            };
            (v, Basis::Interval)
        }
        (None, Some(u)) => {
            let v = if u <= limit {
                Verdict::Pass
            } else {
                Verdict::Undecided
            };
            (v, Basis::UpperLimit)
        }
        (None, None) => (Verdict::NoEstimate, Basis::None),
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_rule() {
        let l = 1.0;
        assert_eq!(
            judge(Some((0.5, 0.9)), None, l),
            (Verdict::Pass, Basis::Interval)
        );
        // The upper end on the limit is still within spec.
        assert_eq!(judge(Some((0.5, 1.0)), None, l).0, Verdict::Pass);
        assert_eq!(
            judge(Some((1.1, 1.5)), None, l),
            (Verdict::Fail, Basis::Interval)
        );
        // The lower end on the limit is not out of spec.
        assert_eq!(judge(Some((1.0, 1.5)), None, l).0, Verdict::Undecided);
        assert_eq!(
            judge(Some((0.9, 1.1)), None, l),
            (Verdict::Undecided, Basis::Interval)
        );
        // An interval wins over an upper limit.
        assert_eq!(judge(Some((2.0, 3.0)), Some(0.1), l).0, Verdict::Fail);
        assert_eq!(
            judge(None, Some(0.8), l),
            (Verdict::Pass, Basis::UpperLimit)
        );
        // Only an upper limit can never fail: the term may be absent.
        assert_eq!(
            judge(None, Some(5.0), l),
            (Verdict::Undecided, Basis::UpperLimit)
        );
        assert_eq!(judge(None, None, l), (Verdict::NoEstimate, Basis::None));
    }
}
