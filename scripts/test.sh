#!/usr/bin/env bash
# Install, build (warnings are errors) and run every test; then once more under
# AddressSanitizer + UndefinedBehaviorSanitizer. This is what .ci/run calls.
set -euo pipefail
cd "$(dirname "$0")/.."
scripts/install-deps.sh
# The code is in the style of .clang-format (a change that is not fails here, before the build).
clang-format --dry-run --Werror $(git ls-files '*.cpp' '*.h' 2>/dev/null || find src apps tests bench -name '*.cpp' -o -name '*.h')
scripts/build.sh
ctest --test-dir build --output-on-failure -j"$(nproc)" | tee build/ctest.log
# A crash-only smoke run of the benchmark (no timing assertions).
build/bench/bench_kernels --benchmark_min_time=0.01 >/dev/null
# Compiled by Clang, not GCC: with the sanitizers' instrumentation GCC takes about twice as long
# (src/hierarchical/hierarchical.cpp: 34-38 s against 17-20 s on this project's 2-core VM), and
# this build was the longest step of CI.
# Warnings are already errors in the GCC build above (the compiler users build with), so they are
# not fatal here. Line tables only (-g1): enough for the sanitizers' stack traces.
CC=clang CXX=clang++ BUILD_DIR=build-asan BUILD_TYPE=RelWithDebInfo scripts/build.sh -DPHOTOMETRIA_SANITIZE=ON \
  -DPHOTOMETRIA_BENCHMARKS=OFF -DPHOTOMETRIA_WERROR=OFF -DCMAKE_CXX_FLAGS_RELWITHDEBINFO="-O2 -g1 -DNDEBUG"
ASAN_OPTIONS=detect_leaks=0 UBSAN_OPTIONS=print_stacktrace=1 \
  ctest --test-dir build-asan --output-on-failure -j"$(nproc)" | tee build-asan/ctest.log
# libFuzzer targets for the loaders (tests/fuzz: OBJ+MTL, JSON scene, JSON queries), built with
# Clang into build-fuzz (the loaders' sources only, tests/fuzz/CMakeLists.txt) and each run for
# 30 s from its seed corpus tests/fuzz/corpus/<target>
# (inputs it finds go to build-fuzz/corpus/<target>; a crash leaves crash-* in build-fuzz).
CC=clang CXX=clang++ cmake -S . -B build-fuzz -DCMAKE_BUILD_TYPE=RelWithDebInfo -DPHOTOMETRIA_FUZZ=ON \
  -DPHOTOMETRIA_WERROR=OFF -DPHOTOMETRIA_BENCHMARKS=OFF >/dev/null
for source in tests/fuzz/fuzz_*.cpp; do
  target=$(basename "$source" .cpp)
  cmake --build build-fuzz -j"$(nproc)" --target "$target"
  mkdir -p "build-fuzz/corpus/$target"
  # libFuzzer is chatty: keep its log in build-fuzz/, show the end (all of it on a failure).
  if ASAN_OPTIONS=detect_leaks=0 "build-fuzz/tests/fuzz/$target" "build-fuzz/corpus/$target" "tests/fuzz/corpus/$target" \
      -max_total_time=30 -timeout=10 -rss_limit_mb=2048 -artifact_prefix=build-fuzz/ -print_final_stats=1 \
      > "build-fuzz/$target.log" 2>&1; then
    echo "fuzz $target: no crash in 30 s ($(grep -c . "build-fuzz/$target.log") log lines)"
    tail -n 12 "build-fuzz/$target.log"
  else
    tail -n 200 "build-fuzz/$target.log"
    echo "fuzz $target: FAILED"
    exit 1
  fi
done
# One closing line for CI: the counts of both CTest runs (pipefail above already failed on any failure).
total() { grep -oE "0 tests failed out of [0-9]+" "$1" | grep -oE "[0-9]+$"; }
n=$(( $(total build/ctest.log) + $(total build-asan/ctest.log) ))
echo "tests: $n passed, 0 failed"
