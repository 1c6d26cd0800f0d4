#!/usr/bin/env bash
# Paired benchmark runs: two builds of the same Google Benchmark binary run alternately, so a
# change in machine load hits both alike. Prints, per benchmark, the median CPU time of each and
# the after/before ratio with the spread of the ratios over the rounds.
#
#   toolchain/bench_pair.sh BEFORE_BIN AFTER_BIN [--filter REGEX] [--rounds N]
#
# Example: toolchain/bench_pair.sh /tmp/old/bin/bench_firmware build/bin/bench_firmware \
#            --filter 'BM_ModelStep|BM_ControllerUpdate$' --rounds 5
set -euo pipefail

usage() {
  sed -n '2,9p' "$0" | sed 's/^# \{0,1\}//'
}

if [[ ${1:-} == --help || ${1:-} == -h ]]; then
  usage
  exit 0
fi
if [[ $# -lt 2 ]]; then
  usage >&2
  exit 2
fi
before=$1
after=$2
shift 2
filter=.
rounds=5
while [[ $# -gt 0 ]]; do
  case $1 in
    --filter) filter=${2:?--filter needs a regex}; shift 2 ;;
    --rounds) rounds=${2:?--rounds needs a count}; shift 2 ;;
    *) echo "bench_pair.sh: unknown argument '$1'" >&2; exit 2 ;;
  esac
done
for bin in "$before" "$after"; do
  [[ -x $bin ]] || { echo "bench_pair.sh: $bin: not an executable" >&2; exit 2; }
done
[[ $rounds =~ ^[1-9][0-9]*$ ]] || { echo "bench_pair.sh: --rounds must be >= 1" >&2; exit 2; }

work=$(mktemp -d)
trap 'rm -rf "$work"' EXIT
for ((r = 1; r <= rounds; r++)); do
  echo "round $r of $rounds" >&2
  for side in before after; do
    bin=$before
    [[ $side == after ]] && bin=$after
    "$bin" --benchmark_filter="$filter" --benchmark_format=json \
      >"$work/$side.$r.json" 2>/dev/null
  done
done

python3 - "$work" "$rounds" <<'EOF'
import json, statistics, sys
work, rounds = sys.argv[1], int(sys.argv[2])
def load(side, r):
    with open(f"{work}/{side}.{r}.json") as f:
        return {b["name"]: b["cpu_time"] * {"ns": 1, "us": 1e3, "ms": 1e6, "s": 1e9}[b["time_unit"]]
                for b in json.load(f)["benchmarks"] if b.get("run_type", "iteration") == "iteration"}
runs = {s: [load(s, r) for r in range(1, rounds + 1)] for s in ("before", "after")}
names = [n for n in runs["after"][0] if n in runs["before"][0]]
def fmt(ns):
    for unit, div in (("s", 1e9), ("ms", 1e6), ("us", 1e3)):
        if ns >= div:
            return f"{ns / div:.3g} {unit}"
    return f"{ns:.3g} ns"
print(f"{'benchmark':60} {'before':>10} {'after':>10} {'ratio':>6}  ratio range")
for n in names:
    b = [runs["before"][r][n] for r in range(rounds)]
    a = [runs["after"][r][n] for r in range(rounds)]
    ratios = sorted(x / y for x, y in zip(a, b))
    print(f"{n:60} {fmt(statistics.median(b)):>10} {fmt(statistics.median(a)):>10} "
          f"{statistics.median(ratios):6.3f}  {ratios[0]:.3f}..{ratios[-1]:.3f}")
EOF
