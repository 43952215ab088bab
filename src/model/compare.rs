//! Agreement of the spectrum and Allan-variance fits, term by term: the two estimates rest on the
//! same data through different filters, so they should agree within their intervals; when they do
//! not, one of the fits is missing an effect (or the PSD's low bins carry a drift the AV sees as
//! ramp).

use serde::Serialize;

use super::{NoiseFit, Term, TermEstimate};

/// One row of the comparison table.
#[derive(Debug, Clone, Copy, PartialEq, Serialize)]
pub struct TermComparison {
    pub term: Term,
    pub allan: Option<TermEstimate>,
    pub spectrum: Option<TermEstimate>,
    /// Spectrum value / Allan value, when both kept the term.
    pub ratio: Option<f64>,
    /// Whether the two intervals overlap, when both kept the term.
    pub overlap: Option<bool>,
}

/// The terms kept by either fit, in [`Term::ALL`] order.
pub fn compare(allan: &NoiseFit, spectrum: &NoiseFit) -> Vec<TermComparison> {
    Term::ALL
        .iter()
        .filter_map(|&term| {
            let a = allan.get(term).copied();
            let s = spectrum.get(term).copied();
            if a.is_none() && s.is_none() {
                return None;
            }
            let (ratio, overlap) = match (a, s) {
                (Some(a), Some(s)) => (Some(s.value / a.value), Some(a.lo <= s.hi && s.lo <= a.hi)),
                _ => (None, None),
            };
            Some(TermComparison {
                term,
                allan: a,
                spectrum: s,
                ratio,
                overlap,
            })
        })
        .collect()
}
