//! One integration-test binary; each area of the library has its own module.
mod support;

mod analyze;
mod avar;
mod bandwidth;
mod cli;
mod gpu;
mod io;
mod mcap;
mod model;
mod psd;
mod readers_prop;
mod real_inputs;
mod residual_loop;
mod residual_loop_catalogue;
mod schema;
mod screen;
mod streaming;
