//! Why a simulation specification was refused.

/// An invalid [`SimSpec`](super::SimSpec): each variant names the field and the value.
#[non_exhaustive]
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum SimError {
    #[error("sample rate must be finite and positive, got {0} Hz")]
    InvalidRate(f64),
    #[error(
        "duration must be finite and give at least 2 samples, got {duration_s} s at {rate_hz} Hz"
    )]
    InvalidDuration { duration_s: f64, rate_hz: f64 },
    #[error("channel {channel:?}: {field} must be finite and non-negative, got {value}")]
    InvalidParameter {
        channel: String,
        field: &'static str,
        value: f64,
    },
    #[error("channel {channel:?}: sinusoid or resonance frequency {freq_hz} Hz is not below the Nyquist frequency {nyquist_hz} Hz")]
    AboveNyquist {
        channel: String,
        freq_hz: f64,
        nyquist_hz: f64,
    },
    #[error("channel {channel:?} has a temperature coefficient but the specification has no temperature")]
    NoTemperature { channel: String },
    #[error("duplicate channel name {0:?}")]
    DuplicateName(String),
    #[error("no channels to simulate")]
    NoChannels,
}
