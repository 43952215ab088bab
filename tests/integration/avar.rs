//! Allan-family estimators: published values (NBS14), Stable32 reference runs, allantools parity,
//! exactness on long data, confidence-interval coverage, and bad input.
//!
//! Every test asserts numbers against an independent source with a stated tolerance; the
//! tolerances are explained next to each assertion.

mod allantools;
mod coverage;
mod errors;
mod nbs14;
mod numerics;
mod stable32;
mod support;
