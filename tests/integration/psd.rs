//! Welch PSD tests (being written).
