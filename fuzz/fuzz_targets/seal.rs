//! libFuzzer's entry for the `seal` target; the body is `mrmm_fuzz::targets::seal`.
#![no_main]

use libfuzzer_sys::fuzz_target;

fuzz_target!(|data: &[u8]| mrmm_fuzz::targets::seal::run(data));
