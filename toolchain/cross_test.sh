#!/usr/bin/env bash
# Cross-builds common/ and firmware/ with their tests for one Arm target and runs the tests
# under qemu-user (CMAKE_CROSSCOMPILING_EMULATOR of toolchain/cmake/*.cmake).
# Usage: toolchain/cross_test.sh aarch64|armhf   (build dir: build-aarch64/ or build-armhf/)
# Then the package test (toolchain/package_test.sh) on this target's package, under qemu-user.
# Run by the native CTest tests cross_aarch64 / cross_armhf (label cross).
# Excluded under emulation, run in the native build: the four tests that run the loop in real
# time on threads (telemetry reader/writer, real-time dry run, SIGTERM, every terminating
# signal, SIGXFSZ ignored), which qemu-user livelocks (a 30 s dry run ignored SIGTERM and ran for 30 min), and
# the death test of a SIGBUS outside any simulated chip, which qemu-user never delivers (the
# test hangs). Also the control-socket and SIGHUP-reload tests: they exec the real-time firmware
# as a child directly (a cross build's emulator prefix does not apply to a direct exec). The bus
# tests (labels fieldbus, hil: I/O threads, sockets, ptys, child processes on a 1 kHz wall
# clock) run natively only for the same reason; their pure parts (codecs, register map, routing
# config, FieldbusIo, GrantClock) run here too. The cross build leaves the executables of the
# natively-run tests out (tests/CMakeLists.txt, mrd_add_test ... EMULATED) and builds the
# harness (hil/) only where an emulated test links it.
set -euo pipefail
cd "$(dirname "$0")/.."
preset="${1:?usage: cross_test.sh aarch64|armhf}"
case "$preset" in aarch64|armhf) ;; *) echo "cross_test: unknown target '$preset'" >&2; exit 2 ;; esac
launcher=()
command -v ccache >/dev/null && launcher=(-DCMAKE_CXX_COMPILER_LAUNCHER=ccache)
# The target's libraries: its sysroot, refreshed to the newest packages its indexes offer.
deb_arch="$preset"; [ "$preset" = aarch64 ] && deb_arch=arm64
sysroot="$(bash toolchain/sysroot.sh "$deb_arch" | tail -n 1)"
cmake --preset "$preset" "${launcher[@]}" -DMRD_SYSROOT="$sysroot" >/dev/null
cmake --build --preset "$preset" -j2
realtime='^(TelemetryTest\.ReaderSeesConsistentSnapshotsWhileWriterRuns|FirmwareCliTest\.RealTimeDryRunRunsAndCountsTime|FirmwareCliTest\.SigtermStopsTheLoopInTheSafeState|FirmwareHardeningTest\.(EveryTerminatingSignalEndsInTheSafeState|SigxfszIsIgnoredAndTheLoopRunsOn|SighupReloadsAndKeepsRunning)|CtlCliTest\..*|SimChipTruncationDeathTest\..*|CanChannelsFirmware\..*)$'
ctest --preset "$preset" -E "$realtime" -LE 'fieldbus|hil' --timeout 300
ctest --preset "$preset" -R '^(CanCodec|DbcTest|ModbusMap|IoConfigTest|FieldbusIoTest|GrantClockTest)\.' \
  --timeout 300
bash toolchain/package_test.sh "build-$preset"
