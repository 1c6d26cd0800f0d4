#!/usr/bin/env bash
# Issue 12 (label vboard): boots the virtual board and checks what it did.
#   1. kernel Image from the cache, or built once (toolchain/vboard/build_kernel.sh)
#   2. aarch64 mrd-firmware and mrd-hil from the cross build in build-aarch64/ (the one the
#      cross_aarch64 test builds: an incremental build of two targets, never a second tree)
#   3. initramfs (make_initramfs.sh), boot under qemu-system-aarch64 (run_vboard.sh): the
#      scenario hil/scenarios/vboard-can-gpio.toml with the firmware on CAN_RAW over vcan0 and
#      libgpiod on a gpio-sim chip; guest clock checked against the host's
#   4. the scenario passed there (check_result.py), its candump log is valid per docs/mrd.dbc
#      (check_candump.py), and its scores agree with the same scenario run in lockstep on the
#      build machine over the local bus + simulated chip (tolerances: check_result.py)
# Usage: tests/vboard/vboard_test.sh NATIVE_BIN_DIR OUT_DIR
set -euo pipefail
src="$(cd "$(dirname "$0")/../.." && pwd)"
bin="${1:?usage: vboard_test.sh NATIVE_BIN_DIR OUT_DIR}"
out="${2:?out dir}"
scenario="$src/hil/scenarios/vboard-can-gpio.toml"
mkdir -p "$out"
t_start=$(date +%s)

echo "== kernel"
t=$(date +%s)
image="$(bash "$src/toolchain/vboard/build_kernel.sh" | tail -1)"
echo "vboard_test: kernel $image ($(( $(date +%s) - t )) s)"

echo "== aarch64 build (build-aarch64/)"
t=$(date +%s)
launcher=()
command -v ccache >/dev/null && launcher=(-DCMAKE_CXX_COMPILER_LAUNCHER=ccache)
(cd "$src" && cmake --preset aarch64 "${launcher[@]}" >/dev/null &&
   cmake --build --preset aarch64 -j2 --target mrd-firmware mrd-hil >/dev/null)
echo "vboard_test: aarch64 mrd-firmware, mrd-hil ($(( $(date +%s) - t )) s)"

echo "== initramfs"
bash "$src/toolchain/vboard/make_initramfs.sh" "$src/build-aarch64" "$scenario" "$out/initrd.cpio.gz"

echo "== boot"
bash "$src/toolchain/vboard/run_vboard.sh" "$image" "$out/initrd.cpio.gz" "$out/board" 900

echo "== the same scenario on the build machine (lockstep, local bus, simulated chip)"
rc=0
"$bin/mrd-hil" run "$scenario" --transport can --clock lockstep --out "$out/native" --json \
  > "$out/native.json" || rc=$?
[ "$rc" -eq 0 ] || { echo "vboard_test: native run exit $rc" >&2; cat "$out/native.json" >&2; exit 1; }

echo "== checks"
# The firmware on the board ran on the real drivers: CAN_RAW on vcan0, libgpiod on gpio-sim.
grep -qx 'interface = "vcan0"' "$out/board/firmware.toml" &&
  grep -q '^chip = "gpiochip[0-9]*"$' "$out/board/firmware.toml" &&
  grep -qx 'source = "displacement"' "$out/board/firmware.toml" ||
  { echo "vboard_test: the board's firmware config is not CAN_RAW + libgpiod + encoder:" >&2
    cat "$out/board/firmware.toml" >&2; exit 1; }
/usr/bin/python3 "$src/toolchain/vboard/check_candump.py" "$src/docs/mrd.dbc" "$out/board/candump.log"
/usr/bin/python3 "$src/tests/vboard/check_result.py" "$out/board/result.json" "$out/native.json"
echo "vboard_test: passed in $(( $(date +%s) - t_start )) s"
