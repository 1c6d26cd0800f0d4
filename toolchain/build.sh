#!/usr/bin/env bash
# Set-up (packages) and build into build/. Executables land in build/bin/.
# Usage: toolchain/build.sh [preset] [--for demo|test|all]
#   preset: release (default) into build/, debug-asan into build-asan/, ...
#   --for:  what the set-up installs (toolchain/setup.sh --for) and what is built:
#           demo builds the programs only (mrd, mrd-firmware, mrd-hil, mrd-structure,
#           mrd-canbus); test and all (the default) build everything, tests included.
# ccache, when installed, caches the compiles outside the clone (~/.cache/ccache).
set -euo pipefail
cd "$(dirname "$0")/.."
preset=release
tier=all
while [ $# -gt 0 ]; do
  case "$1" in
    --for)
      tier="${2:-}"
      shift 2 || { echo "build: error: --for needs demo, test or all" >&2; exit 2; }
      ;;
    --for=*) tier="${1#*=}"; shift ;;
    -*) echo "build: error: unknown option '$1' (usage: build.sh [preset] [--for demo|test|all])" >&2; exit 2 ;;
    *) preset="$1"; shift ;;
  esac
done
case "$tier" in demo | test | all) ;; *) echo "build: error: --for '$tier': demo, test or all" >&2; exit 2 ;; esac
bash toolchain/setup.sh --for "$tier"
launcher=()
command -v ccache >/dev/null && launcher=(-DCMAKE_CXX_COMPILER_LAUNCHER=ccache)
cmake --preset "$preset" "${launcher[@]}" >/dev/null
targets=()
[ "$tier" = demo ] && targets=(--target mrd mrd-firmware mrd-hil mrd-structure mrd-canbus)
cmake --build --preset "$preset" -j "$(nproc)" "${targets[@]}"
