//! imunoise: noise characterisation of inertial sensors (crate docs are replaced by the README later).
pub mod avar;
pub mod io;
pub mod psd;
pub mod quality;
pub mod units;
