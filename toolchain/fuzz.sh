#!/usr/bin/env bash
# Builds the libFuzzer target for the coefficient-table decoder with clang (ASan + UBSan) in
# build-fuzz/ and runs it for a while (default 30 s). Usage: bash toolchain/fuzz.sh [SECONDS]
# Crashing inputs land in build-fuzz/crashes/; the corpus grows in build-fuzz/corpus/.
set -euo pipefail
cd "$(dirname "$0")/.."
seconds="${1:-30}"
command -v clang++ >/dev/null || { echo "fuzz: clang++ is needed (apt-get install clang)" >&2; exit 1; }

cmake -S . -B build-fuzz -G Ninja -DCMAKE_BUILD_TYPE=RelWithDebInfo -DCMAKE_CXX_COMPILER=clang++ \
  -DMRD_FUZZ=ON -DMRD_BUILD_HOST=OFF -DMRD_BUILD_TESTS=OFF -DMRD_BUILD_BENCHMARKS=OFF >/dev/null
cmake --build build-fuzz --target table_decode_fuzz -j2

mkdir -p build-fuzz/corpus build-fuzz/crashes
build-fuzz/bin/table_decode_fuzz --write-seed build-fuzz/corpus
build-fuzz/bin/table_decode_fuzz build-fuzz/corpus -max_len=2200 -max_total_time="$seconds" \
  -print_final_stats=1 -artifact_prefix=build-fuzz/crashes/ 2>&1 | tail -n 25
