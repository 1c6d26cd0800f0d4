#!/usr/bin/env bash
# The harness's concerns in order (hil/CMakeLists.txt): a file of one concern includes
# mrd/hil/<concern>/ headers of its own or an earlier concern only; ports and plants do not
# include each other. Every source and header sits in a concern's folder.
#   tests/hil/concern_order_check.sh HIL_DIR      (exit 1 and the offending lines otherwise)
set -euo pipefail
hil=${1:?usage: concern_order_check.sh HIL_DIR}
declare -A rank=([ports]=0 [plants]=0 [scenario]=2 [run]=3 [study]=4)
bad=0
for f in "$hil"/src/* "$hil"/include/mrd/hil/*; do
  if [[ -f $f ]]; then
    echo "not in a concern's folder: $f"
    bad=1
  fi
done
for dir in "$hil"/src/* "$hil"/include/mrd/hil/*; do
  [[ -d $dir ]] || continue
  own=$(basename "$dir")
  if [[ -z ${rank[$own]+x} ]]; then
    echo "unknown concern: $dir"
    bad=1
    continue
  fi
  while IFS=: read -r file line text; do
    [[ -n $file ]] || continue
    to=$(sed -E 's#.*"mrd/hil/([a-z_]+)/.*#\1#' <<<"$text")
    if [[ $to != "$own" && (-z ${rank[$to]+x} || ${rank[$to]} -ge ${rank[$own]}) ]]; then
      echo "$file:$line: $own includes $to: $text"
      bad=1
    fi
  done < <(grep -Hn '#include "mrd/hil/' "$dir"/* || true)
done
exit $bad
