#!/usr/bin/env bash
# CTest fixture of the hil tests: the paper run's data sets (seed 1), its identification and the
# exported table, once per build (in OUT; reused while the table is newer than mrd and the
# spec that made it).
set -euo pipefail
bin=$1 src=$2 out=$3
if [[ -f "$out/table.bin" && -f "$out/v3.csv" && "$out/table.bin" -nt "$bin/mrd" &&
      "$out/table.bin" -nt "$src/host/specs/paper.toml" ]]; then
  exit 0
fi
mkdir -p "$out"
for p in identification v1 v2 v3; do
  "$bin/mrd" generate --profile "$p" --seed 1 --out "$out/$p.csv" >/dev/null
done
"$bin/mrd" identify --data "$out/identification.csv" --validate "$out/v1.csv,$out/v2.csv,$out/v3.csv" \
  --spec "$src/host/specs/paper.toml" --threads 2 --out "$out/model.json" >"$out/identify.log" 2>&1
"$bin/mrd" export --model "$out/model.json" --table "$out/table.tmp" >/dev/null
mv "$out/table.tmp" "$out/table.bin"
