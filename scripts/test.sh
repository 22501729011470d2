#!/usr/bin/env bash
# Install, build (warnings are errors) and run every test; then once more under
# AddressSanitizer + UndefinedBehaviorSanitizer. This is what .ci/run calls.
set -euo pipefail
cd "$(dirname "$0")/.."
scripts/install-deps.sh
scripts/build.sh
ctest --test-dir build --output-on-failure -j"$(nproc)"
# A crash-only smoke run of the benchmark (no timing assertions).
build/bench/bench_kernels --benchmark_min_time=0.01 >/dev/null
BUILD_DIR=build-asan BUILD_TYPE=RelWithDebInfo scripts/build.sh -DPHOTOMETRIA_SANITIZE=ON -DPHOTOMETRIA_BENCHMARKS=OFF
ASAN_OPTIONS=detect_leaks=0 UBSAN_OPTIONS=print_stacktrace=1 \
  ctest --test-dir build-asan --output-on-failure -j"$(nproc)"
