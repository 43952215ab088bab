//! Noise model (being written).
