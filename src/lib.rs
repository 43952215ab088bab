//! imunoise: noise characterisation of inertial sensors (crate docs are replaced by the README later).
pub mod avar;
pub mod estimate;
pub mod io;
pub mod pipeline;
pub mod psd;
pub mod quality;
pub mod report;
pub mod units;

mod error;
pub use error::Error;
