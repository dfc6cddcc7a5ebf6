//! libFuzzer's entry for the `ros2` target; the body is `mrmm_fuzz::targets::ros2`.
#![no_main]

use libfuzzer_sys::fuzz_target;

fuzz_target!(|data: &[u8]| mrmm_fuzz::targets::ros2::run(data));
