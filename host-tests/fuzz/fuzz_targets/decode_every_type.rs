#![no_main]
//! See host_tests::fuzzing::decode_every_type for what is checked.
libfuzzer_sys::fuzz_target!(|data: &[u8]| host_tests::fuzzing::decode_every_type(data));
