#!/usr/bin/env bash
# C and C++ sources in the style of .clang-format (Google, 100 columns).
#
#   toolchain/format.sh            format every tracked source in place
#   toolchain/format.sh --check    list the sources that differ; exit 1 if any (CI runs this)
#
# Needs clang-format (Debian package clang-format; toolchain/setup.sh installs it). Data
# tables that read better aligned by hand sit between `// clang-format off` and `on`.
set -euo pipefail
cd "$(dirname "$0")/.."
check=0
case "${1:-}" in
  --check) check=1 ;;
  "") ;;
  -h | --help) sed -n '2,8p' "$0" | sed 's/^# \{0,1\}//'; exit 0 ;;
  *) echo "format.sh: unknown argument '$1' (try --help)" >&2; exit 2 ;;
esac
command -v clang-format >/dev/null ||
  { echo "format.sh: clang-format not found (apt-get install clang-format)" >&2; exit 2; }

mapfile -t files < <(git ls-files '*.c' '*.h' '*.cpp' '*.hpp' '*.cpp.in')
if ((check == 0)); then
  clang-format -i --style=file "${files[@]}"
  echo "format.sh: ${#files[@]} files formatted"
  exit 0
fi
bad=()
for f in "${files[@]}"; do
  if ! clang-format --style=file --dry-run --Werror "$f" >/dev/null 2>&1; then bad+=("$f"); fi
done
if ((${#bad[@]} > 0)); then
  printf 'format.sh: not in the style of .clang-format: %s\n' "${bad[@]}" >&2
  echo "format.sh: ${#bad[@]} of ${#files[@]} files differ; run bash toolchain/format.sh" >&2
  exit 1
fi
echo "format.sh: ${#files[@]} files in style"
