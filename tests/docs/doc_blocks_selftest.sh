#!/usr/bin/env bash
# The doc runner fails when it should: a page whose block fails, a block that writes for the
# next one, an unknown flag, a bare flag no command has. Usage: SELF RUNNER SOURCE BIN_DIR
set -uo pipefail
runner="$1" src="$2" bin="$3"
work="$(mktemp -d)"; trap 'rm -rf "$work"' EXIT
failures=0
indent() { while IFS= read -r line; do printf '    %s\n' "$line"; done <<<"$out"; }
expect() {  # expect STATUS DESCRIPTION MODE PAGE
  local want="$1" what="$2" mode="$3" page="$4" got
  out="$(python3 "$runner" "$mode" --source "$src" --bin "$bin" --timeout 60 "$page" 2>&1)"
  got=$?
  if [ "$got" -eq "$want" ]; then echo "ok: $what"; else
    echo "FAIL: $what: exit $got, expected $want"; indent; failures=$((failures + 1)); fi
}
fence='```'
cat >"$work/good.md" <<P
${fence}sh run
mrd generate --profile v2 --seed 1 --out v2.csv
${fence}

${fence}sh run
test -s v2.csv && test -f host/specs/paper.toml && build/bin/mrd --help >/dev/null
${fence}
P
expect 0 "blocks that work pass, in order, in one scratch directory" run "$work/good.md"
sed 's/--profile v2/--profile v9/' "$work/good.md" >"$work/bad.md"
expect 1 "a failing command fails the page" run "$work/bad.md"
if grep -q 'bad.md:1: block failed' <<<"$out"; then echo "ok: the failure names page and line"; else
  echo "FAIL: no 'bad.md:1: block failed' in:"; indent; failures=$((failures + 1)); fi
printf '%s\n' "${fence}sh run" "sleep 300 &" "sleep 30" "${fence}" >"$work/slow.md"
out="$(python3 "$runner" run --source "$src" --bin "$bin" --timeout 2 "$work/slow.md" 2>&1)"
if [ $? -eq 1 ] && grep -q 'timeout after 2' <<<"$out"; then echo "ok: a block past its time limit fails"; else
  echo "FAIL: a block past its time limit:"; indent; failures=$((failures + 1)); fi
# SIGKILL to the block's group is sent when the block ends; the process leaves when the kernel
# next runs it, which on a busy machine can be a moment after the runner returns: look for 5 s.
left=1
for _ in $(seq 50); do pgrep -f '^sleep 300$' >/dev/null || { left=0; break; }; sleep 0.1; done
if [ "$left" -eq 1 ]; then
  echo "FAIL: a process the block left in the background still runs"; failures=$((failures + 1))
else echo "ok: what a block leaves running is killed"; fi
printf '%s\n' "${fence}python run" "import os, sys" "assert os.path.isfile('host/specs/paper.toml')" \
  "print(sys.version)" "${fence}" >"$work/py.md"
expect 0 "a python run block runs in the scratch directory" run "$work/py.md"
printf '%s\n' "${fence}python run" "x = 1" "raise SystemExit('broken example')" "${fence}" >"$work/pybad.md"
expect 1 "a failing python run block fails the page" run "$work/pybad.md"
if grep -q 'pybad.md:1: block failed' <<<"$out" && grep -q 'broken example' <<<"$out"; then
  echo "ok: the python failure names page, line and what it said"; else
  echo "FAIL: no 'pybad.md:1: block failed ... broken example' in:"; indent; failures=$((failures + 1)); fi
printf '%s\n' "${fence}sh" "echo not runnable" "${fence}" >"$work/none.md"
expect 1 "a page without a runnable block fails" run "$work/none.md"
expect 0 "flags of the good page exist" flags "$work/good.md"
printf '%s\n' "${fence}sh" "mrd identify --data a.csv --no-such-flag --spec s.toml --out m.json" "${fence}" >"$work/flag.md"
expect 1 "an unknown flag fails" flags "$work/flag.md"
printf '%s\n' "Run \`mrd simulate --model m.json --data d.csv\`, then add \`--jsonx\`." >"$work/bare.md"
expect 1 "a bare flag no command has fails" flags "$work/bare.md"
echo
[ "$failures" -eq 0 ] || { echo "doc_blocks_selftest: $failures check(s) failed"; exit 1; }
echo "doc_blocks_selftest: every check passed"
