//! libFuzzer's entry for the `central` target; the body is `mrmm_fuzz::targets::central`.
#![no_main]

use libfuzzer_sys::fuzz_target;

fuzz_target!(|data: &[u8]| mrmm_fuzz::targets::central::run(data));
