//! Errors of the PSD module. Each variant carries the numbers involved, because a user who asked for
//! `nperseg = 65536` on a 40 000-sample file needs to see both numbers to choose a smaller segment.

/// Something wrong with a Welch configuration, its input, or a name that should parse into an option.
#[non_exhaustive]
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum PsdError {
    /// Fewer samples than one segment: no periodogram can be formed. scipy silently shrinks `nperseg`
    /// to the input length instead; here that would change the frequency resolution behind the
    /// caller's back, so it is an error.
    #[error("input of {n} samples is shorter than one segment of nperseg = {nperseg} samples")]
    TooShort { n: usize, nperseg: usize },
    /// A combination of options that scipy would also reject (or that has no meaning, such as a
    /// window whose coefficients sum to zero).
    #[error("invalid Welch configuration: {0}")]
    InvalidConfig(String),
    /// A name (window, detrend, scaling, average) that does not parse.
    #[error("unknown {what} {name:?} (expected one of: {expected})")]
    UnknownName {
        what: &'static str,
        name: String,
        expected: &'static str,
    },
    /// A chunk pushed into an accumulator with a different number of channels than it was made for.
    #[error("chunk has {got} channels, the accumulator was made for {expected}")]
    ChannelMismatch { expected: usize, got: usize },
    /// A chunk whose channels have different lengths.
    #[error("channel {channel} of a chunk has {len} samples, channel 0 has {expected}")]
    LengthMismatch {
        channel: usize,
        len: usize,
        expected: usize,
    },
}
