//! Fuzzes the .mcap reader (ROS 2 bags): see common.rs.
#![no_main]

mod common;

libfuzzer_sys::fuzz_target!(|data: &[u8]| common::read(data, "mcap"));
