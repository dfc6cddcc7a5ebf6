//! The fuzz targets' bodies, one module per target: called by its libFuzzer wrapper
//! (`fuzz_targets/<name>.rs`, built by cargo-fuzz on nightly) and by `tests/seeds.rs`, which replays
//! the committed seeds and mutations of them on the stable toolchain in `cargo test`.

pub mod central;
pub mod host;
pub mod recipe;
pub mod robot;
pub mod ros2;
pub mod seal;
