#!/usr/bin/env bash
# toolchain/check_function_length.py on made-up trees: a 150-line function passes, a 151-line
# one fails and is named, a function in a data table listed as allowed passes.
set -euo pipefail
check="$(dirname "$0")/../../toolchain/check_function_length.py"
tmp=$(mktemp -d)
trap 'rm -rf "$tmp"' EXIT
body() {  # NAME LINES: a function whose body spans LINES lines with its braces
  echo "int $1(int a) {"
  for ((i = 0; i < $2 - 2; ++i)); do echo "  a += $i;"; done
  echo "}"
}
mkdir -p "$tmp/common/src"
{ echo "namespace mrd {"; body Short 150; echo "}  // namespace mrd"; } > "$tmp/common/src/a.cpp"
python3 "$check" "$tmp" > /dev/null || { echo "FAIL: a 150-line function refused" >&2; exit 1; }
{ echo "namespace mrd {"; body Long 151; echo "}  // namespace mrd"; } > "$tmp/common/src/b.cpp"
if out=$(python3 "$check" "$tmp" 2> /dev/null); then
  echo "FAIL: a 151-line function passed" >&2
  exit 1
fi
[[ $out == *"common/src/b.cpp:2 Long 151 lines"* ]] || { echo "FAIL: not named: $out" >&2; exit 1; }
echo "function length check: 150 lines pass, 151 fail and are named"
