#!/usr/bin/env bash
# The main job on built-in data: set-up, build, then generate the reference data sets
# (and, as later stages land, identify -> report -> export -> HIL run). Outputs go to out/.
set -euo pipefail
cd "$(dirname "$0")/.."
bash toolchain/build.sh release
mkdir -p out
mrd=build/bin/mrd
echo "== generate: reference data sets (Spencer damper, paper preset, seed 1)"
for p in identification v1 v2 v3; do
  "$mrd" generate --profile "$p" --seed 1 --out "out/$p.csv"
done

echo "== identify: SEM on the identification set, validated on V1-V3 (paper spec)"
"$mrd" identify --data out/identification.csv --validate out/v1.csv,out/v2.csv,out/v3.csv \
  --spec host/specs/paper.toml --threads 2 --out out/model.json
echo "== simulate: selected model on each validation set"
for p in v1 v2 v3; do
  printf '%s: ' "$p"
  "$mrd" simulate --model out/model.json --data "out/$p.csv" --json
done
echo "== report: plots and summary of the model on V1-V3 (out/report/)"
if ! "$mrd" report --model out/model.json --data out/v1.csv,out/v2.csv,out/v3.csv \
    --out out/report 2>out/report.log >out/report.txt; then
  cat out/report.log >&2
  exit 1
fi
sed -n '1,3p;/^fit of/,/^$/p' out/report.txt
echo "   (progress: out/report.log; full summary: out/report/summary.txt; plots: out/report/*.png)"
echo "== export: coefficient table for the firmware"
"$mrd" export --model out/model.json --table out/table.bin --header out/table.hpp
echo "== firmware: 2 s dry run (lockstep) of mrd-firmware on the exported table"
build/bin/mrd-firmware --table out/table.bin --dry-run 2 --lockstep --json
