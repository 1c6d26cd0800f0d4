#!/usr/bin/env bash
# Set-up, build and the test suite (CTest + GoogleTest) in two tiers:
#   toolchain/test.sh [ctest args…]         the tier to trust a build: every native test but
#                                           the statistical campaigns and emulated targets
#   toolchain/test.sh --all [ctest args…]   everything: adds the Arm cross builds under qemu,
#                                           the virtual arm64 board and the statistical
#                                           recovery campaigns (CI runs this)
# Tests only --all runs carry the CTest label `extended`. Other arguments go to ctest, e.g.
# `toolchain/test.sh -L unit`, `toolchain/test.sh --all -L vboard`; an -LE of yours is kept
# (the tier's exclusion is added to it).
set -euo pipefail
cd "$(dirname "$0")/.."
tier="test"
args=()
for a in "$@"; do
  case "$a" in
    --all) tier=all ;;
    -h | --help)
      sed -n '2,10p' "$0" | sed 's/^# \{0,1\}//'
      exit 0
      ;;
    *) args+=("$a") ;;
  esac
done
# The default tier leaves out label `extended`. ctest ANDs repeated -LE options, so a -LE
# given here is merged with it into one alternative.
exclude='^extended$'
rest=()
i=0
while [ "$i" -lt "${#args[@]}" ]; do
  a="${args[$i]}"
  case "$a" in
    -LE | --label-exclude)
      i=$((i + 1))
      [ "$i" -lt "${#args[@]}" ] || { echo "test: error: $a needs a regular expression" >&2; exit 2; }
      exclude="($exclude)|(${args[$i]})"
      ;;
    --label-exclude=*) exclude="($exclude)|(${a#*=})" ;;
    *) rest+=("$a") ;;
  esac
  i=$((i + 1))
done
bash toolchain/build.sh release --for "$tier"
if [ "$tier" = all ]; then
  exec ctest --preset release "${args[@]}"
fi
exec ctest --preset release -LE "$exclude" "${rest[@]}"
