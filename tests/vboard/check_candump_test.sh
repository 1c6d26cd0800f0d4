#!/usr/bin/env bash
# The DBC checker (toolchain/vboard/check_candump.py) on candump_sample.log (the first 400
# frames the virtual board logged on vcan0) and on copies breaking one rule each.
# Usage: check_candump_test.sh SOURCE_DIR WORK_DIR
set -euo pipefail
src="${1:?usage: check_candump_test.sh SOURCE_DIR WORK_DIR}"
work="${2:?work dir}"
mkdir -p "$work"
sample="$src/tests/vboard/candump_sample.log"
check=(/usr/bin/python3 "$src/toolchain/vboard/check_candump.py" "$src/docs/mrd.dbc")
failed=0

expect() {  # expected-exit expected-text file
  local rc=0 out
  out="$("${check[@]}" "$3" 2>&1)" || rc=$?
  if [ "$rc" -ne "$1" ] || ! grep -qF -- "$2" <<<"$out"; then
    echo "FAIL: $3: exit $rc (want $1), output lacks '$2':" >&2
    echo "$out" | head -5 >&2
    failed=1
  else
    echo "ok: $(basename "$3"): exit $rc, '$2'"
  fi
}

expect 0 "senders Firmware" "$sample"
expect 0 "0 errors" "$sample"
# The 10th SensorMotion frame's checksum byte changed.
awk '/ 100#/ && ++n == 10 { b = substr($0, length($0) - 1); $0 = substr($0, 1, length($0) - 2) (b == "00" ? "01" : "00") } { print }' \
  "$sample" > "$work/crc.log"
expect 1 "CRC-8 gives" "$work/crc.log"
# A SensorMotion frame lost: its counter jumps.
awk '/ 100#/ && ++n == 10 { next } { print }' "$sample" > "$work/counter.log"
expect 1 "MotionCounter" "$work/counter.log"
# An ID the DBC does not define.
sed '60s/ vcan0 [0-9A-F]*#/ vcan0 123#/' "$sample" > "$work/id.log"
expect 1 "ID 0x123 not in the DBC" "$work/id.log"
# A frame one byte short.
sed '70s/..$//' "$sample" > "$work/dlc.log"
expect 1 "DLC 7" "$work/dlc.log"
# Only the plant side's frames: one direction missing.
grep -v ' vcan0 080#\| vcan0 300#\| vcan0 081#' "$sample" > "$work/oneway.log"
expect 1 "no frame from the Firmware node" "$work/oneway.log"
# Not a candump -L line: bad input, named by file and line.
{ head -5 "$sample"; echo "garbage"; } > "$work/garbage.log"
expect 2 "garbage.log:6: not a candump -L line" "$work/garbage.log"
expect 2 "cannot read" "$work/missing.log"
exit "$failed"
