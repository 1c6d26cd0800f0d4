#!/usr/bin/env bash
# The firmware's compiled-in table (firmware/include/mrd/firmware/builtin_table.hpp) is the model
# the paper run selects: mrd generate (identification, v1, v2, v3; paper preset, seed 1) ->
# mrd identify (host/specs/paper.toml, validated on V1-V3) -> mrd export --header. The model
# file is kept beside it (firmware/tables/paper_model.json) so the header can be checked
# without identifying again.
#
# Usage: bash toolchain/gen_builtin_table.sh [--from-model | --check] [BIN_DIR]
#   (none)        the whole run: writes firmware/tables/paper_model.json and the header
#   --from-model  the export step only, from the checked-in model file
#   --check       exports from the checked-in model file to a temporary header and compares it
#                 with the checked-in one (exit 1 and a diff when they differ; CTest runs this)
# BIN_DIR: where mrd is (default build/bin).
set -euo pipefail
cd "$(dirname "$0")/.."
mode=all
case "${1:-}" in
  --from-model) mode="export"; shift ;;
  --check) mode=check; shift ;;
  -h|--help) sed -n '2,14p' "$0"; exit 0 ;;
  -*) echo "gen_builtin_table: unknown option $1 (see --help)" >&2; exit 2 ;;
esac
bin=${1:-build/bin}
mrd=$bin/mrd
[[ -x $mrd ]] || { echo "gen_builtin_table: $mrd not found (build it: cmake --build build --target mrd)" >&2; exit 2; }
model=firmware/tables/paper_model.json
header=firmware/include/mrd/firmware/builtin_table.hpp
symbol=mrd::firmware::kBuiltinTable
tmp=$(mktemp -d)
trap 'rm -rf "$tmp"' EXIT
root=$PWD
if [[ $mode == all ]]; then
  echo "gen_builtin_table: generate (paper preset, seed 1)"
  for p in identification v1 v2 v3; do
    (cd "$tmp" && "$root/$mrd" generate --profile "$p" --seed 1 --out "$p.csv" >/dev/null)
  done
  echo "gen_builtin_table: identify (host/specs/paper.toml; about 15 s on 2 cores)"
  (cd "$tmp" && "$root/$mrd" identify --data identification.csv --validate v1.csv,v2.csv,v3.csv \
     --spec "$root/host/specs/paper.toml" --threads 2 --out model.json >identify.log 2>&1) || {
    cat "$tmp/identify.log" >&2; exit 1; }
  tail -n 1 "$tmp/identify.log"
  mv "$tmp/model.json" "$model.tmp" && mv "$model.tmp" "$model"
fi
"$mrd" export --model "$model" --header "$tmp/builtin_table.hpp" --symbol "$symbol" >/dev/null
if [[ $mode == check ]]; then
  if ! cmp -s "$tmp/builtin_table.hpp" "$header"; then
    echo "gen_builtin_table: $header is not what $model exports; regenerate with" >&2
    echo "  bash toolchain/gen_builtin_table.sh --from-model" >&2
    diff -u "$header" "$tmp/builtin_table.hpp" | head -40 >&2 || true
    exit 1
  fi
  echo "gen_builtin_table: $header equals the export of $model"
  exit 0
fi
mv "$tmp/builtin_table.hpp" "$header.tmp" && mv "$header.tmp" "$header"
echo "gen_builtin_table: wrote $header from $model"
