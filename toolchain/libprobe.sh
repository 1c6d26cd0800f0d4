#!/usr/bin/env bash
# Cross-builds toolchain/libprobe (libmodbus + libgpiod through pkg-config, as firmware/io
# links them) for one Arm target and runs it under qemu-user: proves the target's libraries
# in the target's sysroot (toolchain/sysroot.sh) are there and usable.
# Usage: toolchain/libprobe.sh aarch64|armhf
# Run by the native CTest tests cross_libs_aarch64 / cross_libs_armhf (label cross).
set -euo pipefail
cd "$(dirname "$0")/.."
case "${1:-}" in
  aarch64) toolchain=aarch64-linux-gnu; deb=arm64; qemu="qemu-aarch64"; bits=64 ;;
  armhf) toolchain=arm-linux-gnueabihf; deb=armhf; qemu="qemu-arm"; bits=32 ;;
  *) echo "usage: libprobe.sh aarch64|armhf" >&2; exit 2 ;;
esac
sysroot="$(bash toolchain/sysroot.sh "$deb" | tail -n 1)"
dir="$(mktemp -d)"
trap 'rm -rf "$dir"' EXIT
cmake -S toolchain/libprobe -B "$dir" -G Ninja -DCMAKE_BUILD_TYPE=Release \
  -DCMAKE_TOOLCHAIN_FILE="$PWD/toolchain/cmake/$toolchain.cmake" -DMRD_SYSROOT="$sysroot" \
  >"$dir/configure.log" ||
  { cat "$dir/configure.log"; exit 1; }
cmake --build "$dir" >/dev/null
out="$("$qemu" -L "$sysroot" "$dir/libprobe")"  # qemu-user refuses a build-machine binary
echo "$out"
grep -q "pointer $bits bits" <<<"$out"
