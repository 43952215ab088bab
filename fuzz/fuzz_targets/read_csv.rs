//! Fuzzes the .csv reader: see common.rs.
#![no_main]

mod common;

libfuzzer_sys::fuzz_target!(|data: &[u8]| common::read(data, "csv"));
