#!/usr/bin/env bash
# The main job on built-in data: set-up, build, then generate the reference data sets
# (and, as later stages land, identify -> export -> HIL run). Outputs go to out/.
set -euo pipefail
cd "$(dirname "$0")/.."
bash toolchain/build.sh release
mkdir -p out
mrd=build/bin/mrd
echo "== generate: reference data sets (Spencer damper, paper preset, seed 1)"
for p in identification v1 v2 v3; do
  "$mrd" generate --profile "$p" --seed 1 --out "out/$p.csv"
done
