//! One integration-test binary; each area of the library has its own module.
mod avar;
mod psd;
