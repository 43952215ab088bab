//! Tau grids: which averaging factors m (τ = m/rate) to evaluate.
//!
//! A grid is a value, not a string, so a typo fails when the configuration is parsed rather than an
//! hour into a run; [`FromStr`] and [`Display`](fmt::Display) give it the spelling the CLI uses.

use std::fmt;
use std::str::FromStr;

use super::{AvarError, Statistic};

/// Which averaging factors m to evaluate. m is in samples, τ = m/fs.
///
/// Every grid is cut to the factors valid for the statistic and the data length (at least two
/// terms in the estimator, see [`Statistic::max_factor`]), the convention allantools applies when
/// it drops results with one term.
#[derive(Debug, Clone, PartialEq, Eq, serde::Serialize, serde::Deserialize)]
#[serde(rename_all = "kebab-case")]
pub enum TauGrid {
    /// m = 1, 2, 4, 8, …: one point per octave, the usual grid for noise fitting.
    Octave,
    /// m = 1, 2, 5, 10, 20, 50, …
    Decade125,
    /// About n log-spaced factors per decade: m = round(10^(k/n)), k = 0, 1, …, duplicates removed.
    PerDecade(u32),
    /// Every m from 1 to the largest valid one (slow on long data: one full pass per m).
    All,
    /// Exactly these factors (sorted and deduplicated).
    Explicit(Vec<u64>),
}

impl TauGrid {
    /// The averaging factors of this grid for `n_samples` samples and `stat`: sorted, unique, every
    /// one valid (at least two estimator terms). Zero factors of an explicit list are dropped here;
    /// [`compute`](super::compute) reports them as errors instead.
    pub fn factors(&self, n_samples: usize, stat: Statistic) -> Vec<u64> {
        let max = stat.max_factor(n_samples);
        let mut out: Vec<u64> = match self {
            TauGrid::Octave => (0..64)
                .map(|k| 1u64 << k)
                .take_while(|&m| m <= max)
                .collect(),
            TauGrid::Decade125 => decade_125(max),
            TauGrid::PerDecade(n) => per_decade(*n, max),
            TauGrid::All => (1..=max).collect(),
            TauGrid::Explicit(list) => list
                .iter()
                .copied()
                .filter(|&m| m >= 1 && m <= max)
                .collect(),
        };
        out.sort_unstable();
        out.dedup();
        out
    }
}

/// 1, 2, 5 × 10^k up to `max`.
fn decade_125(max: u64) -> Vec<u64> {
    let mut out = Vec::new();
    let mut decade = 1u64;
    'outer: loop {
        for f in [1u64, 2, 5] {
            match decade.checked_mul(f) {
                Some(m) if m <= max => out.push(m),
                _ => break 'outer,
            }
        }
        match decade.checked_mul(10) {
            Some(d) => decade = d,
            None => break,
        }
    }
    out
}

/// round(10^(k/n)) for k = 0, 1, … up to `max`, without duplicates (at small m several k round to
/// the same integer).
fn per_decade(n: u32, max: u64) -> Vec<u64> {
    let mut out: Vec<u64> = Vec::new();
    if n == 0 {
        return out;
    }
    for k in 0u32.. {
        let m = 10f64.powf(f64::from(k) / f64::from(n)).round();
        if m.is_nan() || m > max as f64 {
            break;
        }
        let m = m as u64;
        if out.last() != Some(&m) {
            out.push(m);
        }
    }
    out
}

impl fmt::Display for TauGrid {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            TauGrid::Octave => f.write_str("octave"),
            TauGrid::Decade125 => f.write_str("decade"),
            TauGrid::PerDecade(n) => write!(f, "per-decade:{n}"),
            TauGrid::All => f.write_str("all"),
            TauGrid::Explicit(list) => {
                let parts: Vec<String> = list.iter().map(u64::to_string).collect();
                f.write_str(&parts.join(","))
            }
        }
    }
}

const GRID_SPELLINGS: &str =
    "octave, decade, all, per-decade:N (or N-per-decade), or a comma-separated list of factors m";

impl FromStr for TauGrid {
    type Err = AvarError;

    /// Parses `octave`, `decade` (or `decade125`), `all`, `per-decade:N` (or `N-per-decade`) and
    /// comma-separated lists of averaging factors such as `1,2,5,100`.
    fn from_str(s: &str) -> Result<Self, Self::Err> {
        let bad = || AvarError::UnknownName {
            what: "tau grid",
            name: s.to_string(),
            expected: GRID_SPELLINGS,
        };
        let key = s.trim().to_ascii_lowercase();
        match key.as_str() {
            "octave" => return Ok(TauGrid::Octave),
            "decade" | "decade125" => return Ok(TauGrid::Decade125),
            "all" => return Ok(TauGrid::All),
            _ => {}
        }
        let per_decade = key
            .strip_prefix("per-decade:")
            .or_else(|| key.strip_suffix("-per-decade"));
        if let Some(n) = per_decade {
            return match n.trim().parse::<u32>() {
                Ok(n) if n > 0 => Ok(TauGrid::PerDecade(n)),
                _ => Err(bad()),
            };
        }
        let list: Result<Vec<u64>, _> = key.split(',').map(|p| p.trim().parse::<u64>()).collect();
        match list {
            Ok(list) if !list.is_empty() && list.iter().all(|&m| m > 0) => {
                Ok(TauGrid::Explicit(list))
            }
            _ => Err(bad()),
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn octave_stops_at_the_statistic_limit() {
        assert_eq!(
            TauGrid::Octave.factors(1000, Statistic::Oadev),
            vec![1, 2, 4, 8, 16, 32, 64, 128, 256]
        );
        // Non-overlapping Hadamard needs 4m samples.
        assert_eq!(
            TauGrid::Octave.factors(1000, Statistic::Hdev),
            vec![1, 2, 4, 8, 16, 32, 64, 128]
        );
        assert!(TauGrid::Octave.factors(2, Statistic::Oadev).is_empty());
    }

    #[test]
    fn decade_and_per_decade() {
        assert_eq!(
            TauGrid::Decade125.factors(1001, Statistic::Oadev),
            vec![1, 2, 5, 10, 20, 50, 100, 200, 500]
        );
        assert_eq!(
            TauGrid::PerDecade(4).factors(201, Statistic::Oadev),
            vec![1, 2, 3, 6, 10, 18, 32, 56, 100]
        );
        assert!(TauGrid::PerDecade(0)
            .factors(1000, Statistic::Oadev)
            .is_empty());
        let grid = TauGrid::PerDecade(10).factors(10_000_000, Statistic::Oadev);
        assert!(grid.windows(2).all(|w| w[0] < w[1]));
        assert_eq!(*grid.last().unwrap(), 3_981_072);
    }

    #[test]
    fn all_and_explicit() {
        assert_eq!(TauGrid::All.factors(9, Statistic::Oadev), vec![1, 2, 3, 4]);
        assert_eq!(
            TauGrid::Explicit(vec![5, 1, 0, 5, 400, 2]).factors(100, Statistic::Oadev),
            vec![1, 2, 5]
        );
    }

    #[test]
    fn spellings_round_trip() {
        for g in [
            TauGrid::Octave,
            TauGrid::Decade125,
            TauGrid::All,
            TauGrid::PerDecade(10),
            TauGrid::Explicit(vec![1, 2, 5, 100]),
        ] {
            assert_eq!(g.to_string().parse::<TauGrid>().unwrap(), g);
        }
        assert_eq!(
            "10-per-decade".parse::<TauGrid>().unwrap(),
            TauGrid::PerDecade(10)
        );
        assert_eq!(" Octave ".parse::<TauGrid>().unwrap(), TauGrid::Octave);
        for bad in ["", "per-decade:0", "1,0", "1,x", "weekly", "-3"] {
            assert!(bad.parse::<TauGrid>().is_err(), "{bad:?}");
        }
    }
}
