#!/usr/bin/env bash
# toolchain/mutate.sh --check refuses a list with a duplicate group name (two groups of one name:
# the selector would run the wrong group's tests), a duplicate mutant id and an unknown group,
# each naming the line; it accepts a well-formed list.
set -euo pipefail
root=$(cd "$(dirname "$0")/../.." && pwd)
dir=$(mktemp -d)
trap 'rm -rf "$dir"' EXIT
check() {  # LIST EXPECTED-RC EXPECTED-MESSAGE
  local rc=0 out
  out=$(MRD_MUTANTS="$1" bash "$root/toolchain/mutate.sh" --check 2>&1) || rc=$?
  if [[ $rc != "$2" || $out != *"$3"* ]]; then
    echo "FAIL: $1: rc=$rc (want $2), output: $out (want: $3)"
    exit 1
  fi
}
orig='firmware/src/loop.cpp	const std::uint32_t others = faulted_ & ~(1U << i);	x'
printf 'group\tg\tt\tr\nmutant\tA1\t%s\tg\td\n' "$orig" > "$dir/ok.tsv"
check "$dir/ok.tsv" 0 "1 mutants, 1 groups"
printf 'group\tg\tt\tr\ngroup\tg\tt\tr\n' > "$dir/group.tsv"
check "$dir/group.tsv" 1 "group.tsv:2: duplicate group g"
printf 'group\tg\tt\tr\nmutant\tA1\t%s\tg\td\nmutant\tA1\t%s\tg\td\n' "$orig" "$orig" > "$dir/id.tsv"
check "$dir/id.tsv" 1 "id.tsv:3: duplicate mutant id A1"
printf 'group\tg\tt\tr\nmutant\tA1\t%s\th\td\n' "$orig" > "$dir/unknown.tsv"
check "$dir/unknown.tsv" 1 "unknown.tsv:2: unknown group h"
echo "mutation list checks: ok"
