#![doc = include_str!("../README.md")]
//!
//! # Library map
//! Data flows one way: [`io`] (read, convert to SI) → [`quality`] (screen, apply policies) →
//! [`estimate`] (a [`estimate::Backend`]: [`psd`] Welch and [`avar`] Allan family) → [`report`]
//! (tables and JSON). [`pipeline::run`] takes one recording through all of it; the CLI is a thin
//! layer over it.
pub mod analysis;
pub mod avar;
pub mod effects;
pub mod estimate;
pub mod fleet;
pub mod gpu;
pub mod io;
pub mod memo;
pub mod memory;
pub mod model;
pub mod pipeline;
pub mod psd;
pub mod quality;
pub mod report;
pub mod sim;
pub mod stats;
pub mod units;

mod error;
pub use error::Error;
