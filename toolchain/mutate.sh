#!/usr/bin/env bash
# Mutation check: applies each mutant of toolchain/mutants.tsv (a one-line textual change) to a
# scratch copy of the tree, rebuilds the mutant's test targets, runs its tests, reverts, and
# prints KILLED / SURVIVED / INVALID per mutant and the score killed / (killed + survived).
#
#   toolchain/mutate.sh [SELECTOR...]
#   toolchain/mutate.sh --check      (the list only: every original text found exactly once in
#                                     the tree, ids and group names unique, groups known; no build;
#                                     a CTest test)
#
# SELECTOR: a mutant id (C01), an area (common, firmware, host) or a test group of the list
# (see the `group` lines); none: every mutant. Takes minutes: run by hand, and before resolving
# an issue that touches the real-time path. Not part of the test command.
#
# Verdicts: KILLED: a selected test failed or timed out (a hang counts as killed, the tests do
# not pass); SURVIVED: all selected tests passed; INVALID: the mutant does not compile (not
# counted in the score). A mutant whose original text is not found exactly once in its file
# stops the run (exit 3): the list is stale.
#
# Environment: MRD_MUTATE_DIR (scratch, default /tmp/mrd-mutate), MRD_MUTATE_JOBS (2),
# MRD_MUTATE_TIMEOUT (per test [s], 300), MRD_MUTANTS (list, toolchain/mutants.tsv),
# MRD_MUTATE_MIN_SCORE (exit 1 below this score [%], 90).
set -euo pipefail

root=$(cd "$(dirname "$0")/.." && pwd)
list=${MRD_MUTANTS:-$root/toolchain/mutants.tsv}
check_only=0
[[ ${1:-} == --check ]] && { check_only=1; shift; }
scratch=${MRD_MUTATE_DIR:-/tmp/mrd-mutate}
jobs=${MRD_MUTATE_JOBS:-2}
timeout=${MRD_MUTATE_TIMEOUT:-300}
min_score=${MRD_MUTATE_MIN_SCORE:-90}
py=/usr/bin/python3
[[ -x $py ]] || py=python3

# The list: "group<TAB>name<TAB>targets<TAB>ctest regex" and
# "mutant<TAB>id<TAB>file<TAB>original<TAB>replacement<TAB>group<TAB>description".
# Selected mutants as id|file|group|description lines, and groups as name|targets|regex lines.
# With check_root set: only checks that every selected original text is found exactly once
# below it (exit 3 and a line per stale mutant otherwise).
read_list() {
  check_root=$check_root "$py" - "$list" "$@" <<'EOF'
import os, sys
path, selectors = sys.argv[1], set(sys.argv[2:])
groups, mutants, ids = {}, [], set()
for n, line in enumerate(open(path, encoding="utf-8"), 1):
    line = line.rstrip("\n")
    if not line or line.startswith("#"):
        continue
    f = line.split("\t")
    if f[0] == "group" and len(f) == 4:
        if f[1] in groups:
            sys.exit(f"error: {path}:{n}: duplicate group {f[1]}")
        groups[f[1]] = f[2:]
    elif f[0] == "mutant" and len(f) == 7:
        if f[1] in ids:
            sys.exit(f"error: {path}:{n}: duplicate mutant id {f[1]}")
        ids.add(f[1])
        if f[5] not in groups:
            sys.exit(f"error: {path}:{n}: unknown group {f[5]}")
        mutants.append(f[1:])
    else:
        sys.exit(f"error: {path}:{n}: expected a group (4 fields) or mutant (7 fields) line")
def selected(mid, file, group):
    return not selectors or bool(selectors & {mid, file.split("/")[0], group})
if os.environ.get("check_root"):
    stale = 0
    for mid, file, orig, _, group, _ in mutants:
        if not selected(mid, file, group):
            continue
        try:
            with open(os.path.join(os.environ["check_root"], file), encoding="utf-8") as f:
                count = f.read().count(orig)
        except OSError as e:
            count = f"no file ({e.strerror})"
        if count != 1:
            stale += 1
            print(f"error: {path}: mutant {mid}: original text found {count} times in {file}: "
                  f"{orig!r}", file=sys.stderr)
    print(f"{len(mutants)} mutants, {len(groups)} groups" + (f", {stale} stale" if stale else ""))
    sys.exit(3 if stale else 0)
for mid, file, orig, repl, group, desc in mutants:
    if selected(mid, file, group):
        print("M", mid, file, group, desc, sep="\t")
for name, (targets, regex) in groups.items():
    print("G", name, targets, regex, sep="\t")
EOF
}

check_root=""
if ((check_only)); then
  check_root=$root
  read_list
  exit
fi

src=$scratch/src
build=$scratch/build
log=$scratch/log
mkdir -p "$src" "$build" "$log"

# Scratch copy of the working tree (tracked and untracked sources, no build trees, no .git).
# Only files that differ are copied (new mtime), so the scratch build stays incremental and an
# interrupted run's mutated file is replaced and rebuilt.
(cd "$root" && find . \( -path ./.git -o -path './build*' -o -path ./.cache \) -prune -o \
   -type f -print0) |
  while IFS= read -r -d '' f; do
    if ! cmp -s "$root/$f" "$src/$f"; then
      mkdir -p "$(dirname "$src/$f")"
      cp "$root/$f" "$src/$f"
    fi
  done

# apply FILE ID: replaces the mutant's original text (exactly one occurrence) in the scratch
# copy; exit 3 when it is not found exactly once.
apply() {
  "$py" - "$list" "$1" "$src" <<'EOF'
import sys
path, mid, src = sys.argv[1:4]
for line in open(path, encoding="utf-8"):
    f = line.rstrip("\n").split("\t")
    if f[0] == "mutant" and f[1] == mid:
        _, _, file, orig, repl, _, _ = f
        text = open(f"{src}/{file}", encoding="utf-8").read()
        count = text.count(orig)
        if count != 1:
            print(f"error: {path}: mutant {mid}: original text found {count} times in {file}: "
                  f"{orig!r}", file=sys.stderr)
            sys.exit(3)
        open(f"{src}/{file}", "w", encoding="utf-8").write(text.replace(orig, repl))
        sys.exit(0)
sys.exit(f"error: {path}: no mutant {mid}")
EOF
}

declare -A g_targets g_regex
mutant_lines=()
while IFS=$'\t' read -r kind a b c d; do
  if [[ $kind == G ]]; then
    g_targets[$a]=$b
    g_regex[$a]=$c
  else
    mutant_lines+=("$a"$'\t'"$b"$'\t'"$c"$'\t'"$d")
  fi
done < <(read_list "$@")
[[ ${#mutant_lines[@]} -gt 0 ]] || { echo "error: no mutant matches: $*" >&2; exit 2; }

# Every selected original text must be found exactly once before anything runs.
check_root=$src read_list "$@" >/dev/null || exit 3

launcher=()  # ccache (when installed) makes each mutant's rebuild after the revert cheap
command -v ccache >/dev/null && launcher=(-DCMAKE_CXX_COMPILER_LAUNCHER=ccache)
cmake -S "$src" -B "$build" -G Ninja -DCMAKE_BUILD_TYPE=Release -DMRD_BUILD_BENCHMARKS=OFF \
  "${launcher[@]}" >"$log/configure.txt" 2>&1 ||
  { echo "error: configure failed (see $log/configure.txt)" >&2; exit 1; }

used_groups=$(for m in "${mutant_lines[@]}"; do cut -f3 <<<"$m"; done | sort -u)

# Baseline: the unmutated tree must build and pass every selected group.
for g in $used_groups; do
  # shellcheck disable=SC2086
  cmake --build "$build" -j "$jobs" --target ${g_targets[$g]} >"$log/baseline-$g.txt" 2>&1 ||
    { echo "error: baseline build of group $g failed (see $log/baseline-$g.txt)" >&2; exit 1; }
  ctest --test-dir "$build" -R "${g_regex[$g]}" -j "$jobs" --timeout "$timeout" \
    >>"$log/baseline-$g.txt" 2>&1 ||
    { echo "error: baseline tests of group $g fail (see $log/baseline-$g.txt)" >&2; exit 1; }
done

killed=0 survived=0 invalid=0
start=$(date +%s)
results=$scratch/results.tsv
: >"$results"
for m in "${mutant_lines[@]}"; do
  IFS=$'\t' read -r id file group desc <<<"$m"
  cp "$src/$file" "$scratch/orig"
  apply "$id"
  t0=$(date +%s)
  # shellcheck disable=SC2086
  if ! cmake --build "$build" -j "$jobs" --target ${g_targets[$group]} >"$log/$id.txt" 2>&1; then
    verdict=INVALID
    invalid=$((invalid + 1))
  elif ctest --test-dir "$build" -R "${g_regex[$group]}" -j "$jobs" --timeout "$timeout" \
      >>"$log/$id.txt" 2>&1; then
    verdict=SURVIVED
    survived=$((survived + 1))
  else
    verdict=KILLED
    killed=$((killed + 1))
  fi
  cp "$scratch/orig" "$src/$file"
  touch "$src/$file"  # the next build recompiles it
  failed=$(grep -oE '[0-9]+ - [A-Za-z0-9_./]+ \((Failed|Timeout)\)' "$log/$id.txt" | head -3 |
           sed -E 's/^[0-9]+ - //' | paste -sd' ' || true)
  printf '%-4s %-8s %4ss  %s%s\n' "$id" "$verdict" "$(($(date +%s) - t0))" "$desc" \
    "${failed:+  [$failed]}"
  printf '%s\t%s\t%s\t%s\n' "$id" "$verdict" "$desc" "$failed" >>"$results"
done
# Leave the scratch build matching the tree.
for g in $used_groups; do
  # shellcheck disable=SC2086
  cmake --build "$build" -j "$jobs" --target ${g_targets[$g]} >/dev/null 2>&1 || true
done

total=$((killed + survived))
score=$(awk -v k=$killed -v t=$total 'BEGIN { printf "%.1f", t ? 100 * k / t : 0 }')
echo "mutants: ${#mutant_lines[@]}  killed: $killed  survived: $survived  invalid: $invalid" \
  " score: $score % ($killed/$total)  wall: $(($(date +%s) - start)) s"
echo "per-mutant logs: $log/  results: $results"
awk -v s="$score" -v m="$min_score" 'BEGIN { exit !(s >= m) }'
