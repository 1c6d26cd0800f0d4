#!/usr/bin/env bash
# The firmware core's boundary, checked on the built archive: every symbol the core
# (libmrd_firmware.a) leaves undefined must be defined by the core's own libraries (given after it:
# the core itself and mrd::common) or be on the allow-list below (libm, the compiler's
# runtime helpers, memory copies, operator new/delete for start-up allocation). A call to open(),
# read(), socket() or any other I/O from a core file shows up here as an undefined symbol and
# fails the check, naming the symbol and the object that needs it.
#
# Usage: check_core_symbols.sh NM CORE.a [OWN.a ...]
set -euo pipefail
nm_tool=$1
core=$2
shift 2

# Defined by the core and its own libraries (global text, data, bss, weak, unique).
defined=$(for a in "$core" "$@"; do "$nm_tool" --defined-only -g "$a" 2>/dev/null; done |
  awk 'NF >= 3 { print $3 }' | sort -u)

# libm and the C/C++ runtime pieces a pure computation may need (mangled names).
allowed='^(_GLOBAL_OFFSET_TABLE_|__stack_chk_fail|__stack_chk_guard|__dso_handle'
allowed+='|mem(cpy|set|move|cmp)|__mem(cpy|set|move)_chk'
allowed+='|(exp|log|log10|log2|sqrt|pow|fabs|fmax|fmin|tanh|sinh|cosh|sin|cos|tan|atan|atan2|floor|ceil|round|lround|trunc|hypot|copysign|fmod|cbrt|expm1|log1p)f?'
allowed+='|_Zdl.*|_Znw.*|_Zda.*|_Zna.*'        # operator delete/new (start-up allocation)
allowed+='|__cxa_guard_(acquire|release|abort)|__cxa_atexit|__cxa_pure_virtual'
allowed+='|__libc_single_threaded|_ZNSt19_Sp_make_shared_tag5_S_eqERKSt9type_info'  # std::shared_ptr (the shared model)
allowed+='|__aeabi_.*|__aarch64_.*|__(add|sub|mul|div|neg|fix|float|extend|trunc|cmp|eq|ne|lt|le|gt|ge|unord)[a-z]*[0-9]+'
allowed+='|__popcount[sd]i2|__clz[sd]i2|__ctz[sd]i2|__udivmod[dt]i4|__u?(div|mod)[dt]i3)$'

fail=0
while read -r obj sym; do
  if [[ $sym =~ $allowed ]]; then continue; fi
  echo "core boundary: $obj calls $(c++filt -- "$sym" 2>/dev/null || echo "$sym") ($sym): not the" \
    "core's own and not on the allow-list (I/O belongs in firmware/io or firmware/platform)" >&2
  fail=1
done < <("$nm_tool" -u -A "$core" | sed -E 's/^[^:]*:([^:]*):[[:space:]]*U[[:space:]]+/\1 /' |
  sort -u | awk 'NR == FNR { own[$1] = 1; next } !($2 in own)' <(echo "$defined") -)

if [[ $fail -ne 0 ]]; then exit 1; fi
echo "core boundary: $(basename "$core"): every undefined symbol is the core's own, libm's or the runtime's"
