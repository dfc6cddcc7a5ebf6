#!/usr/bin/env bash
# Runs every fuzz target from its committed seeds: fuzz/run.sh [SECONDS] [TARGET...], each for
# SECONDS or FUZZ_RUNS executions (default 10 000 000), whichever ends first. Needs the nightly
# toolchain and cargo-fuzz (.ci/run installs it and runs a short pass). Findings: fuzz/artifacts/.
set -euo pipefail
cd "$(dirname "$0")/.."
secs=${1:-1800}
shift || true
targets=("$@")
[ ${#targets[@]} -gt 0 ] || targets=(recipe central host robot seal ros2)
for t in "${targets[@]}"; do
  mkdir -p "fuzz/corpus/$t"
  cargo +nightly fuzz run -O --features libfuzzer --target-dir "${FUZZ_TARGET_DIR:-fuzz/target}" "$t" "fuzz/corpus/$t" "fuzz/seeds/$t" -- \
    -max_total_time="$secs" -runs="${FUZZ_RUNS:-10000000}" -timeout=10 -rss_limit_mb=4096 -print_final_stats=1
done
