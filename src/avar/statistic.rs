//! The statistics of the Allan family that this module estimates, with the few facts about each that
//! the rest of the module needs: how many terms its estimator has, how many samples that takes, and
//! which finite difference it is built on (which is also what the EDF and noise identification need).

use std::fmt;
use std::str::FromStr;

use super::AvarError;

/// An Allan-family statistic of rate (frequency-type) data.
///
/// All are written with the cumulative sum S of the mean-removed rate samples (S₀ = 0, N samples,
/// τ = m·τ₀), so that a τ-average is (S_{j+m} − S_j)/m:
///
/// | statistic | estimator (variance) | terms |
/// |---|---|---|
/// | `Oadev` | Σ_{j=0}^{N−2m} (S_{j+2m} − 2S_{j+m} + S_j)² / (2m²·terms) | N − 2m + 1 |
/// | `Adev` | same sum over j = 0, m, 2m, … | ⌊N/m⌋ − 1 |
/// | `Mdev` | Σ_j (Σ_{i=j}^{j+m−1} (S_{i+2m} − 2S_{i+m} + S_i))² / (2m⁴·terms) | N − 3m + 2 |
/// | `Hdev` | Σ_{j=0,m,2m,…} (S_{j+3m} − 3S_{j+2m} + 3S_{j+m} − S_j)² / (6m²·terms) | ⌊N/m⌋ − 2 |
/// | `Ohdev` | the same third differences at every j | N − 3m + 1 |
///
/// These are NIST SP 1065's estimators for frequency data and give the same numbers as allantools'
/// `oadev`, `adev`, `mdev`, `hdev` and `ohdev` with `data_type="freq"`. `Hdev` is the classic
/// (non-overlapping) Hadamard deviation: it is the one whose values SP 1065 publishes for the NBS14
/// test set and the one allantools calls `hdev`; `Ohdev` is its overlapping form, which has better
/// confidence for the same data.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, serde::Serialize, serde::Deserialize)]
#[serde(rename_all = "lowercase")]
pub enum Statistic {
    /// Overlapping Allan deviation: the general-purpose first choice.
    Oadev,
    /// Non-overlapping (classic) Allan deviation.
    Adev,
    /// Modified Allan deviation: separates white from flicker phase (angle) noise.
    Mdev,
    /// Hadamard deviation (non-overlapping): insensitive to a constant rate ramp.
    Hdev,
    /// Overlapping Hadamard deviation.
    Ohdev,
}

impl Statistic {
    /// Every statistic, in a fixed order (handy for tests and for "all statistics" options).
    pub const ALL: [Statistic; 5] = [
        Statistic::Oadev,
        Statistic::Adev,
        Statistic::Mdev,
        Statistic::Hdev,
        Statistic::Ohdev,
    ];

    /// The short lower-case name, as parsed by [`FromStr`] and printed by [`Display`](fmt::Display).
    pub fn name(self) -> &'static str {
        match self {
            Statistic::Oadev => "oadev",
            Statistic::Adev => "adev",
            Statistic::Mdev => "mdev",
            Statistic::Hdev => "hdev",
            Statistic::Ohdev => "ohdev",
        }
    }

    /// Order of the finite difference of phase (of S) the estimator squares: 2 for the Allan
    /// variances, 3 for the Hadamard ones. Greenhall's EDF calls it d.
    pub fn difference_order(self) -> u8 {
        match self {
            Statistic::Oadev | Statistic::Adev | Statistic::Mdev => 2,
            Statistic::Hdev | Statistic::Ohdev => 3,
        }
    }

    /// Whether the estimator uses every start index j (stride 1) rather than j = 0, m, 2m, ….
    pub fn overlapping(self) -> bool {
        matches!(self, Statistic::Oadev | Statistic::Mdev | Statistic::Ohdev)
    }

    /// Whether the estimator averages m phase differences before squaring (the "modified" family).
    pub fn modified(self) -> bool {
        matches!(self, Statistic::Mdev)
    }

    /// Number of terms (squared differences) the estimator averages for `n_samples` rate samples at
    /// averaging factor `m`; 0 when m = 0 or the data are too short for a single term.
    pub fn n_terms(self, n_samples: usize, m: u64) -> u64 {
        let n = n_samples as u64;
        if m == 0 {
            return 0;
        }
        let span = u64::from(self.difference_order()) * m; // S_{j+span} is the last value used
        match self {
            Statistic::Oadev | Statistic::Ohdev => (n + 1).saturating_sub(span),
            Statistic::Adev => (n / m).saturating_sub(1),
            Statistic::Hdev => (n / m).saturating_sub(2),
            Statistic::Mdev => (n + 2).saturating_sub(3 * m),
        }
    }

    /// Smallest number of rate samples for which the estimator has at least two terms at averaging
    /// factor `m` (one term gives a number but no spread, which allantools also drops).
    pub fn min_samples(self, m: u64) -> usize {
        let m = m.max(1);
        let needed = match self {
            Statistic::Oadev => 2 * m + 1,
            Statistic::Adev => 3 * m,
            Statistic::Mdev => 3 * m,
            Statistic::Hdev => 4 * m,
            Statistic::Ohdev => 3 * m + 1,
        };
        usize::try_from(needed).unwrap_or(usize::MAX)
    }

    /// Largest averaging factor with at least two terms on `n_samples` samples (0 if none).
    pub fn max_factor(self, n_samples: usize) -> u64 {
        let n = n_samples as u64;
        match self {
            Statistic::Oadev => n.saturating_sub(1) / 2,
            Statistic::Adev | Statistic::Mdev => n / 3,
            Statistic::Hdev => n / 4,
            Statistic::Ohdev => n.saturating_sub(1) / 3,
        }
    }

    /// Most negative power-law exponent α (S_y ∝ f^α) the statistic converges for: α > 1 − 2d,
    /// so −2 (random-walk rate) for the Allan variances and −4 for the Hadamard ones.
    pub fn alpha_min(self) -> i8 {
        match self.difference_order() {
            2 => -2,
            _ => -4,
        }
    }
}

impl fmt::Display for Statistic {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str(self.name())
    }
}

impl FromStr for Statistic {
    type Err = AvarError;

    fn from_str(s: &str) -> Result<Self, Self::Err> {
        let key = s.trim().to_ascii_lowercase();
        Statistic::ALL
            .into_iter()
            .find(|st| st.name() == key)
            .ok_or(AvarError::UnknownName {
                what: "statistic",
                name: s.to_string(),
                expected: "oadev, adev, mdev, hdev or ohdev",
            })
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn min_samples_is_where_two_terms_start() {
        for st in Statistic::ALL {
            for m in 1..40u64 {
                let n = st.min_samples(m);
                assert!(st.n_terms(n, m) >= 2, "{st} m={m} n={n}");
                assert!(st.n_terms(n - 1, m) < 2, "{st} m={m} n={}", n - 1);
                assert!(st.max_factor(n) >= m, "{st} m={m}");
            }
        }
    }

    #[test]
    fn max_factor_is_largest_with_two_terms() {
        for st in Statistic::ALL {
            for n in 0..200usize {
                let mx = st.max_factor(n);
                if mx > 0 {
                    assert!(st.n_terms(n, mx) >= 2, "{st} n={n} m={mx}");
                }
                assert!(st.n_terms(n, mx + 1) < 2, "{st} n={n} m={}", mx + 1);
            }
        }
    }

    #[test]
    fn names_round_trip() {
        for st in Statistic::ALL {
            assert_eq!(st.to_string().parse::<Statistic>().unwrap(), st);
            assert_eq!(st.name().to_uppercase().parse::<Statistic>().unwrap(), st);
        }
        assert!(matches!(
            "tdev".parse::<Statistic>(),
            Err(AvarError::UnknownName { .. })
        ));
    }
}
