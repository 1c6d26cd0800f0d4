#!/usr/bin/env bash
# Cross-builds toolchain/libprobe (libmodbus + libgpiod through pkg-config, as firmware/io
# links them) for one Arm target and runs it under qemu-user: proves the target's libraries
# from toolchain/setup.sh are there and usable. Usage: toolchain/libprobe.sh aarch64|armhf
# Run by the native CTest tests cross_libs_aarch64 / cross_libs_armhf (label cross).
set -euo pipefail
cd "$(dirname "$0")/.."
case "${1:-}" in
  aarch64) toolchain=aarch64-linux-gnu; bits=64 ;;
  armhf) toolchain=arm-linux-gnueabihf; bits=32 ;;
  *) echo "usage: libprobe.sh aarch64|armhf" >&2; exit 2 ;;
esac
dir="$(mktemp -d)"
trap 'rm -rf "$dir"' EXIT
cmake -S toolchain/libprobe -B "$dir" -G Ninja -DCMAKE_BUILD_TYPE=Release \
  -DCMAKE_TOOLCHAIN_FILE="$PWD/toolchain/cmake/$toolchain.cmake" >"$dir/configure.log" ||
  { cat "$dir/configure.log"; exit 1; }
cmake --build "$dir" >/dev/null
emulator="$(sed -n 's/^set(CMAKE_CROSSCOMPILING_EMULATOR \(.*\))$/\1/p' "toolchain/cmake/$toolchain.cmake")"
out="$($emulator "$dir/libprobe")"  # qemu-user refuses a build-machine binary
echo "$out"
grep -q "pointer $bits bits" <<<"$out"
