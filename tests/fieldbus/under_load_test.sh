#!/usr/bin/env bash
# Real-time tests beside a load that keeps every core busy: starts one CPU hog per core (a
# shell loop at normal priority, as `yes >/dev/null`), runs each named CTest test RUNS times
# one after the other, stops the hogs, and prints "N passed, M failed" per test and in total.
# Exit 0 only when every run passed. Usage:
#   tests/fieldbus/under_load_test.sh BUILD_DIR RUNS TEST_REGEX...
# e.g. tests/fieldbus/under_load_test.sh build 10 \
#        '^ModbusProfileNoAllocTest\.LoopPeriodsOverTcpAllocateNothing$' \
#        '^Transports/ModbusSafeTimingTest\.FirstSafeBlockWithinTwoPeriodsOfTheLoopGoingSafe/rtu( |$)'
set -euo pipefail
build="${1:?usage: under_load_test.sh BUILD_DIR RUNS TEST_REGEX...}"
runs="${2:?runs}"
shift 2
[ $# -gt 0 ] || { echo "under_load_test: no test named" >&2; exit 2; }
hogs=()
stop_hogs() {
  local p
  for p in "${hogs[@]}"; do kill "$p" 2>/dev/null || true; done
  for p in "${hogs[@]}"; do wait "$p" 2>/dev/null || true; done
  hogs=()
}
trap stop_hogs EXIT
cores="$(nproc)"
for _ in $(seq "$cores"); do
  (while :; do :; done) &
  hogs+=("$!")
done
echo "under_load_test: $cores CPU hogs (pids ${hogs[*]}), $runs runs of each test"
log="$(mktemp)"
total_pass=0
total_fail=0
for regex in "$@"; do
  pass=0
  fail=0
  for i in $(seq "$runs"); do
    # Exactly one test per regex: a regex matching none must not pass silently.
    if ctest --test-dir "$build" -R "$regex" --output-on-failure >"$log" 2>&1 &&
        grep -q '100% tests passed, 0 tests failed out of 1$' "$log"; then
      pass=$((pass + 1))
    else
      fail=$((fail + 1))
      echo "under_load_test: $regex run $i FAILED (load $(cut -d' ' -f1 /proc/loadavg)):"
      grep -E "Failure|Expected|actual|first safe|allocat|Which is" "$log" | head -n 20
    fi
  done
  echo "under_load_test: $regex: $pass passed, $fail failed (load $(cut -d' ' -f1 /proc/loadavg))"
  total_pass=$((total_pass + pass))
  total_fail=$((total_fail + fail))
done
rm -f "$log"
stop_hogs
echo "$total_pass passed, $total_fail failed"
[ "$total_fail" -eq 0 ]
