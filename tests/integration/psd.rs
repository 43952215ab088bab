//! Welch PSD: parity with scipy, streaming, calibration, log-binning, bad input, and the fast path
//! against the direct-sum reference.

mod calibration;
mod common;
mod errors;
mod logbin;
mod parity;
mod reference;
mod streaming;
