//! CPU mirrors of the kernels: plain Rust functions with the kernels' names, constants and loop
//! structure, in the same precision, written to be read side by side with the WGSL. Each kernel is
//! tested against its mirror (an indexing or twiddle slip shows up as a large difference, rounding
//! as a tiny one), and the mirrors themselves are tested against textbook references (a direct DFT,
//! the CPU Welch and Allan estimators), so the chain kernel → mirror → reference is checked link by
//! link.

pub mod avar;
pub mod fft;
pub mod welch;
