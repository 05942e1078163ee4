#![no_main]
//! See host_tests::differential for what is checked.
libfuzzer_sys::fuzz_target!(|data: &[u8]| host_tests::differential::decode_paths(data));
