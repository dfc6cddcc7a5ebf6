//! libFuzzer's entry for the `recipe` target; the body is `mrmm_fuzz::targets::recipe`.
#![no_main]

use libfuzzer_sys::fuzz_target;

fuzz_target!(|data: &[u8]| mrmm_fuzz::targets::recipe::run(data));
