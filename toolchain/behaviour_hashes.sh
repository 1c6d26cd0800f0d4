#!/usr/bin/env bash
# Fingerprints of what the tools compute, to prove a restructuring changed no behaviour:
# the paper run's model file, the NEES model file and the summary of every HIL scenario
# (lockstep, compiled-in table; the smoke scenario also over Modbus TCP and RTU), each as a
# SHA-256 with the exit code. Wall-clock fields (timing, elapsed seconds, worst latency, memory
# lock, scheduling, the per-period log's counters: its writer flushes on a wall-clock timer) and
# the scratch directory's name are dropped before hashing.
#
#   toolchain/behaviour_hashes.sh [BIN_DIR] > hashes.txt      (BIN_DIR default build/bin)
#   diff before.txt after.txt
set -euo pipefail
cd "$(dirname "$0")/.."
bin=$(realpath "${1:-build/bin}")
work=$(mktemp -d)
trap 'rm -rf "$work"' EXIT

# A JSON file's hash without its wall-clock fields; the scratch directory reads WORK.
hash_json() {
  python3 -c '
import hashlib, json, sys
WALL = {"timing", "elapsed_s", "worst_exec_us", "worst_latency_us", "memory_locked",
        "sched_fifo", "log"}
def strip(o):
    if isinstance(o, dict):
        return {k: strip(v) for k, v in o.items() if k not in WALL}
    if isinstance(o, list):
        return [strip(v) for v in o]
    if isinstance(o, str):
        return o.replace(sys.argv[2], "WORK")
    return o
d = strip(json.load(open(sys.argv[1])))
print(hashlib.sha256(json.dumps(d, sort_keys=True).encode()).hexdigest())
' "$1" "$work"
}

# Reference data, paper spec (the demo's identification run).
for p in identification v1 v2 v3; do
  "$bin/mrd" generate --profile "$p" --seed 1 --out "$work/$p.csv" >/dev/null
done
"$bin/mrd" identify --data "$work/identification.csv" \
  --validate "$work/v1.csv,$work/v2.csv,$work/v3.csv" --spec host/specs/paper.toml \
  --threads 2 --out "$work/paper.json" >/dev/null 2>&1
echo "model paper $(hash_json "$work/paper.json")"

# Measured bench run, NEES spec.
nees=tests/data/nees-2012-1158/ransim_u.csv
"$bin/mrd" import --in "$nees" --map t=t,x=D,v=V,E=Y,f=F --rate 1000 --out "$work/nees.csv" \
  >/dev/null 2>&1
"$bin/mrd" slice --in "$work/nees.csv" --from 0 --to 14 --out "$work/nees-id.csv" >/dev/null
"$bin/mrd" identify --data "$work/nees-id.csv" --spec host/specs/nees.toml --threads 2 \
  --out "$work/nees.json" >/dev/null 2>&1
echo "model nees $(hash_json "$work/nees.json")"
echo "data nees $(sha256sum "$work/nees.csv" | cut -d' ' -f1)"

# Every scenario, lockstep; the exit code is part of the fingerprint.
runs=()
for s in hil/scenarios/*.toml; do runs+=("$(basename "$s" .toml)|$s|can"); done
runs+=("closed-loop-smoke-modbus-tcp|hil/scenarios/closed-loop-smoke.toml|modbus-tcp")
runs+=("closed-loop-smoke-modbus-rtu|hil/scenarios/closed-loop-smoke.toml|modbus-rtu")
for r in "${runs[@]}"; do
  IFS='|' read -r name s transport <<<"$r"
  out="$work/hil-$name"
  rc=0
  "$bin/mrd-hil" run "$s" --clock lockstep --transport "$transport" \
    --firmware "$bin/mrd-firmware" --out "$out" >/dev/null 2>"$work/$name.err" || rc=$?
  if [[ -f "$out/summary.json" ]]; then
    h=$(hash_json "$out/summary.json")
  else
    h="no-summary:$(head -c 200 "$work/$name.err" | tr '\n' ' ' | sed "s|$work|WORK|g")"
  fi
  echo "hil $name rc=$rc $h"
done
