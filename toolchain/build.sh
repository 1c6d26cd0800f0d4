#!/usr/bin/env bash
# Set-up (packages) and Release build into build/. Executables land in build/bin/.
# Usage: toolchain/build.sh [preset]   (default: release; debug-asan builds into build-asan/)
set -euo pipefail
cd "$(dirname "$0")/.."
preset="${1:-release}"
bash toolchain/setup.sh
cmake --preset "$preset" >/dev/null
cmake --build --preset "$preset" -j "$(nproc)"
