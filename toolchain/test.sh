#!/usr/bin/env bash
# Set-up, build and run the whole test suite (CTest + GoogleTest).
# Usage: toolchain/test.sh [ctest args…]   e.g. toolchain/test.sh -L unit
set -euo pipefail
cd "$(dirname "$0")/.."
bash toolchain/build.sh release
ctest --preset release "$@"
