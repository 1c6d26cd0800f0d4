#!/usr/bin/env bash
# Runs shellcheck (Debian's package, installed by toolchain/setup.sh) on every shell script under
# toolchain/, .ci/, packaging/ and tests/setup/: a script is a *.sh file or a file whose first
# line names sh or bash. Any finding, at any severity, fails.
set -euo pipefail
cd "$(dirname "$0")/../.."
command -v shellcheck >/dev/null || { echo "shellcheck_test: shellcheck not installed (toolchain/setup.sh)" >&2; exit 1; }
scripts=()
while IFS= read -r -d '' f; do
  case "$f" in
    *.sh) scripts+=("$f") ;;
    *) head -n 1 "$f" | grep -qE '^#!.*\b(ba)?sh\b' && scripts+=("$f") ;;
  esac
done < <(find toolchain .ci packaging tests/setup -type f -print0 | sort -z)
[ ${#scripts[@]} -gt 10 ] || { echo "shellcheck_test: only ${#scripts[@]} scripts found" >&2; exit 1; }
echo "shellcheck $(shellcheck --version | sed -n 's/^version: //p') on ${#scripts[@]} scripts"
shellcheck -x "${scripts[@]}"
echo "shellcheck_test: no findings"
