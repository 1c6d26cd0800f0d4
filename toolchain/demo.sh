#!/usr/bin/env bash
# The main job on built-in data: set-up, build, then generate the reference data sets
# -> identify -> simulate -> report -> export -> firmware dry run -> HIL closed loop (mrd-hil +
# mrd-firmware over the local CAN bus), then the same on the measured NEES run shipped in
# tests/data/nees-2012-1158. Outputs go to out/.
set -euo pipefail
cd "$(dirname "$0")/.."
bash toolchain/build.sh release --for demo
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

echo "== HIL: mrd-hil + mrd-firmware closed loop over the local CAN bus (lockstep), exported table"
echo "   force tracking on V1's forces (reachable by construction), every sensor fault, then"
echo "   skyhook on a quarter car (ISO 8608 class C road, 20 m/s) against passive-off and -on"
build/bin/mrd-hil run hil/scenarios/force-v1.toml --excitation out/v1.csv --table out/table.bin \
  --out out/hil/force-v1
build/bin/mrd-hil run hil/scenarios/faults-sensor.toml --table out/table.bin --out out/hil/faults
build/bin/mrd-hil run hil/scenarios/quarter-car-skyhook.toml --table out/table.bin \
  --out out/hil/quarter-car
echo "   (summaries, traces and plots: out/hil/*/)"

nees=tests/data/nees-2012-1158/ransim_u.csv
if [[ -f "$nees" ]]; then
  echo "== real bench data: NEES-2012-1158 run -> import -> identify (0-14 s) -> held-out 14-19.5 s"
  mkdir -p out/nees
  "$mrd" import --in "$nees" --map t=t,x=D,v=V,E=Y,f=F --rate 1000 --out out/nees/nees.csv \
    >out/nees/import.log
  "$mrd" slice --in out/nees/nees.csv --from 0 --to 14 --out out/nees/id.csv
  "$mrd" slice --in out/nees/nees.csv --from 14 --to 19.5 --out out/nees/held.csv
  "$mrd" identify --data out/nees/id.csv --spec host/specs/nees.toml --threads 2 \
    --out out/nees/model.json >out/nees/identify.log
  tail -n 1 out/nees/identify.log
  printf 'held out: '
  "$mrd" simulate --model out/nees/model.json --data out/nees/held.csv --json
  "$mrd" report --model out/nees/model.json --data out/nees/held.csv,out/nees/id.csv \
    --out out/nees/report >/dev/null 2>out/nees/report.log
  echo "   (plots and summary: out/nees/report/)"
else
  echo "== real bench data: skipped ($nees not found)"
fi
