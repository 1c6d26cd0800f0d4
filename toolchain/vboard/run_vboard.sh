#!/usr/bin/env bash
# Boots the virtual board: qemu-system-aarch64 -M virt -cpu cortex-a53 -accel tcg (no KVM on
# the build machines) with the kernel and initramfs, console on the PL011 (ttyAMA0) into
# OUT_DIR/console.log, `timeout` as the hard limit. The guest's /init (init.sh) powers off
# through PSCI, which ends QEMU. From the console log: OUT_DIR/result.json (mrd-hil run --json)
# and OUT_DIR/candump.log. Checks the guest's clock against the host's: the guest's uptime at
# its power-off within the host's elapsed time (at most 1 s more, at most 30 s less: boot and
# start-up), and its wall clock (PL031 RTC) within 5 s of the host's.
# Prints "vboard: ..." figures; exit 0 when the guest delivered a result and its clock is sane,
# 1 otherwise (console.log tells why).
# Usage: toolchain/vboard/run_vboard.sh IMAGE INITRD OUT_DIR [TIMEOUT_S (600)]
set -euo pipefail
image="${1:?usage: run_vboard.sh IMAGE INITRD OUT_DIR [TIMEOUT_S]}"
initrd="${2:?initrd}"
out="${3:?out dir}"
limit="${4:-600}"
mkdir -p "$out"
console="$out/console.log"
rm -f "$console" "$out/result.json" "$out/candump.log"
t0=$(date +%s.%N)
set +e
timeout --kill-after=10 "$limit" qemu-system-aarch64 -M virt -cpu cortex-a53 -accel tcg \
  -smp 1 -m 512M -nic none -display none -monitor none -serial "file:$console" -no-reboot \
  -kernel "$image" -initrd "$initrd" -append "console=ttyAMA0 panic=-1 loglevel=4" </dev/null
rc=$?
set -e
t1=$(date +%s.%N)
host_elapsed=$(awk -v a="$t0" -v b="$t1" 'BEGIN { printf "%.2f", b - a }')
echo "vboard: qemu exit $rc after ${host_elapsed} s (limit ${limit} s)"
if [ "$rc" -eq 124 ] || [ "$rc" -eq 137 ]; then
  echo "vboard: timed out; console tail:" >&2
  tail -n 30 "$console" >&2
  exit 1
fi
between() {  # marker -> the console lines between ===MARKER-BEGIN=== and ===MARKER-END===
  tr -d '\r' < "$console" | sed -n "/^===$1-BEGIN===\$/,/^===$1-END===\$/p" | sed '1d;$d'
}
grep -a '^VBOARD-' "$console" | tr -d '\r' || true
between MRD-RESULT > "$out/result.json"
between MRD-CANDUMP | base64 -d 2>/dev/null | gunzip > "$out/candump.log" 2>/dev/null || true
between MRD-STDERR > "$out/guest_stderr.log"
between MRD-CONFIG > "$out/firmware.toml"
if [ ! -s "$out/result.json" ]; then
  echo "vboard: no result on the console; tail:" >&2
  tail -n 40 "$console" >&2
  exit 1
fi
# The guest's clock.
end_line="$(tr -d '\r' < "$console" | grep -a '^VBOARD-CLOCK end' || true)"
if [ -z "$end_line" ]; then
  echo "vboard: the guest never reported its clock at the end" >&2
  exit 1
fi
guest_up=$(sed -n 's/.*uptime=\([0-9.]*\).*/\1/p' <<<"$end_line")
guest_epoch=$(sed -n 's/.*epoch=\([0-9]*\).*/\1/p' <<<"$end_line")
host_epoch=$(date +%s)
run_line="$(tr -d '\r' < "$console" | grep -a '^VBOARD-RUN' || true)"
run_s=$(awk -v l="$run_line" 'BEGIN { n = split(l, f, /[ =]/); for (i = 1; i < n; ++i) { if (f[i] == "start") s = f[i+1]; if (f[i] == "end") e = f[i+1] } printf "%.2f", e - s }')
echo "vboard: guest uptime at power-off ${guest_up} s, host elapsed ${host_elapsed} s; scenario ${run_s} s (guest clock)"
echo "vboard: guest wall clock $guest_epoch, host $host_epoch"
awk -v g="$guest_up" -v h="$host_elapsed" -v ge="$guest_epoch" -v he="$host_epoch" 'BEGIN {
  ok = g <= h + 1 && g >= h - 30 && ge - he <= 5 && he - ge <= 5
  if (!ok) { print "vboard: the guest clock is not sane" > "/dev/stderr"; exit 1 }
}'
echo "vboard: boot + scenario + power-off ${host_elapsed} s; result in $out/result.json, bus log $out/candump.log ($(wc -l < "$out/candump.log") frames)"
