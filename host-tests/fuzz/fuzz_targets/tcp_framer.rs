#![no_main]
//! See host_tests::fuzzing::tcp_framer for what is checked.
libfuzzer_sys::fuzz_target!(|data: &[u8]| host_tests::fuzzing::tcp_framer(data));
