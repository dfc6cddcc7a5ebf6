//! libFuzzer's entry for the `host` target; the body is `mrmm_fuzz::targets::host`.
#![no_main]

use libfuzzer_sys::fuzz_target;

fuzz_target!(|data: &[u8]| mrmm_fuzz::targets::host::run(data));
