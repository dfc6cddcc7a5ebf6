//! libFuzzer's entry for the `robot` target; the body is `mrmm_fuzz::targets::robot`.
#![no_main]

use libfuzzer_sys::fuzz_target;

fuzz_target!(|data: &[u8]| mrmm_fuzz::targets::robot::run(data));
