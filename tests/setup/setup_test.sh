#!/usr/bin/env bash
# shellcheck disable=SC2016  # the checks' bash -c programs expand their own arguments
# toolchain/setup.sh's decisions against fake dpkg-query, dpkg, apt-get, apt-cache, id and sudo
# on PATH (nothing is installed, nothing needs root). Each case sets what is installed and what
# the apt indexes offer, runs the script and checks its exit status, its message and the
# install calls it made. Usage: setup_test.sh [SETUP_SCRIPT]   (default: toolchain/setup.sh)
set -uo pipefail
here="$(cd "$(dirname "$0")" && pwd)"
script="$(readlink -f "${1:-$here/../../toolchain/setup.sh}")"
work="$(mktemp -d)"
trap 'rm -rf "$work"' EXIT
real_dpkg="$(command -v dpkg)"

# The package lists of the tiers, read from the script (one word per package, comments
# dropped): demo_packages, then what test adds, then what all adds; `all` is the union.
list() {
  sed -n "/^$1=(/,/^)/p" "$script" | sed '1d;$d;s/#.*//' | tr ' ' '\n' | sed 's/:.*//' |
    grep -v '^$' | sort -u
}
mapfile -t demo < <(list demo_packages)
mapfile -t test_only < <(list test_packages)
mapfile -t all_only < <(list all_packages)
all=("${demo[@]}" "${test_only[@]}" "${all_only[@]}")
if [ ${#demo[@]} -le 10 ] || [ ${#test_only[@]} -eq 0 ] || [ ${#all_only[@]} -eq 0 ]; then
  echo "FAIL: could not read the package lists of $script"; exit 1
fi

fakes="$work/bin"
mkdir -p "$fakes"
# State: $FAKE/installed and $FAKE/offered hold "package version" lines; $FAKE/calls logs
# every apt-get call ("sudo apt-get" when run through sudo); $FAKE/uid is the user id; $FAKE/update_fail, when present, is
# what apt-get update prints before it fails; $FAKE/install_fail makes apt-get install fail.
# The fakes read their state with bash alone: setup.sh asks about each of a hundred packages in
# every case, and a process per lookup made this test cost minutes of CPU time.
cat >"$fakes/dpkg-query" <<'F'
#!/usr/bin/env bash
p="${@: -1}"; p="${p%%:*}"
while read -r n v; do
  [ "$n" = "$p" ] && { printf 'install ok installed %s' "$v"; exit 0; }
done <"$FAKE/installed"
echo "dpkg-query: no packages found matching $p" >&2; exit 1
F
cat >"$fakes/dpkg" <<F
#!/usr/bin/env bash
case "\$1" in
  --print-architecture) echo amd64 ;;
  --print-foreign-architectures) : ;;
  --add-architecture) echo "dpkg \$*" >>"\$FAKE/calls" ;;
  --compare-versions) exec "$real_dpkg" "\$@" ;;
  *) echo "fake dpkg: \$*" >>"\$FAKE/calls"; exit 1 ;;
esac
F
cat >"$fakes/apt-cache" <<'F'
#!/usr/bin/env bash
case "$1" in
  policy)
    p="${2%%:*}"; v=""
    while read -r n o; do [ "$n" = "$p" ] && { v="$o"; break; }; done <"$FAKE/offered"
    echo "$p:"; echo "  Installed: (none)"; echo "  Candidate: ${v:-(none)}" ;;
  madison)
    p="${2%%:*}"; awk -v p="$p" '$1 == p { print p " | " $2 " | http://deb.debian.org/debian bookworm/main" }' "$FAKE/offered" ;;
esac
F
cat >"$fakes/apt-get" <<'F'
#!/usr/bin/env bash
echo "${FAKE_SUDO:+sudo }apt-get $*" >>"$FAKE/calls"
read -r uid <"$FAKE/uid"
if [ "$uid" != 0 ] && [ -z "${FAKE_SUDO:-}" ]; then
  echo "E: Could not open lock file /var/lib/dpkg/lock-frontend - open (13: Permission denied)" >&2
  echo "E: Unable to acquire the dpkg frontend lock, are you root?" >&2; exit 100
fi
args=(); for a in "$@"; do case "$a" in -*|DPkg::*) ;; *) args+=("$a") ;; esac; done
case "${args[0]}" in
  update) if [ -f "$FAKE/update_fail" ]; then cat "$FAKE/update_fail"; exit 100; fi ;;
  install)
    [ -f "$FAKE/install_fail" ] && { echo "E: Unable to locate package x" >&2; exit 100; }
    for p in "${args[@]:1}"; do
      name="${p%%=*}"; name="${name%%:*}"; v=""
      while read -r n o; do [ "$n" = "$name" ] && { v="$o"; break; }; done <"$FAKE/offered"
      [ -n "$v" ] || { echo "E: Unable to locate package $name" >&2; exit 100; }
      kept=(); while IFS= read -r l; do [[ $l == "$name "* ]] || kept+=("$l"); done <"$FAKE/installed"
      { [ ${#kept[@]} -eq 0 ] || printf '%s\n' "${kept[@]}"; echo "$name $v"; } >"$FAKE/installed"
    done ;;
esac
F
cat >"$fakes/id" <<'F'
#!/usr/bin/env bash
read -r uid <"$FAKE/uid"
case "$1" in -u) echo "$uid" ;; -un) echo user ;; *) echo "uid=$uid" ;; esac
F
cat >"$fakes/sudo" <<'F'
#!/usr/bin/env bash
FAKE_SUDO=1 exec "$@"
F
chmod +x "$fakes"/*
# A PATH of the fakes and the standard tools, without sudo unless a case adds it.
tools="$work/tools"
mkdir -p "$tools"
for t in bash sh sed awk grep cat mktemp rm mv tr head tail sort cut wc env readlink dirname \
         basename printf; do
  src="$(command -v "$t")" && ln -sf "$src" "$tools/$t"
done

failures=0
state=""
args=()  # the script's arguments in the next run
indent() { sed 's/^/    /' "$@"; }
new_case() {  # new_case NAME: an empty state, running as root with sudo absent
  state="$work/case-$1"; mkdir -p "$state"
  : >"$state/installed"; : >"$state/calls"; echo 0 >"$state/uid"
  for p in "${all[@]}" libmodbus5 libmodbus-dev libgpiod2 libgpiod-dev; do
    echo "$p 1.0-1" >>"$state/offered"
  done
}
offer() { grep -v "^$1 " "$state/offered" >"$state/o" || true; echo "$1 $2" >>"$state/o"; mv "$state/o" "$state/offered"; }
install() { echo "$1 $2" >>"$state/installed"; }
run() {  # run [with-sudo]: runs the script; sets status, out
  local path="$fakes:$tools"
  if [ "${1:-}" != with-sudo ]; then
    mkdir -p "$state/nosudo"; for f in "$fakes"/*; do [ "${f##*/}" = sudo ] || ln -sf "$f" "$state/nosudo/"; done
    path="$state/nosudo:$tools"
  fi
  out="$(cd "$work" && FAKE="$state" PATH="$path" bash "$script" "${args[@]}" 2>&1)"
  status=$?
  # Never a silent failure: a non-zero exit always says what failed.
  if [ "$status" -ne 0 ] && ! grep -q '^setup: error: ' <<<"$out"; then
    echo "FAIL: ${state##*/case-}: exit $status with no 'setup: error:' line"
    indent <<<"$out"
    failures=$((failures + 1))
  fi
}
check() {  # check DESCRIPTION CONDITION...
  local what="$1"; shift
  if "$@"; then echo "ok: $what"; else echo "FAIL: $what"; echo "  exit status: $status"; echo "  output:"; indent <<<"$out"; echo "  calls:"; indent "$state/calls"; failures=$((failures + 1)); fi
}
calls() { cat "$state/calls"; }
# Whether each (none) of the named packages has a line in the state's installed list.
installed_names() { local n _; declare -gA have=(); while read -r n _; do have[$n]=1; done <"$state/installed"; }
installed_each() { installed_names; for p in "$@"; do [ -n "${have[$p]:-}" ] || return 1; done; }
installed_all() { installed_each "${all[@]}"; }
installed_none() { installed_names; for p in "$@"; do [ -z "${have[$p]:-}" ] || return 1; done; return 0; }
# The packages named by the install calls (options and the apt-get words dropped).
install_named() {
  grep 'apt-get .*install' "$state/calls" | tr ' ' '\n' | grep -v '^-' |
    grep -vxE 'sudo|apt-get|install|DPkg::Lock::Timeout=[0-9]+' | sort -u
}
same_set() { [ "$(printf '%s\n' "${@:2}" | sort -u)" = "$(install_named)" ] || { echo "  install calls named: $(install_named | tr '\n' ' ')"; echo "  expected ($1): $(printf '%s ' "${@:2}")"; return 1; }; }
no_downgrade() { ! grep -qE -- '--allow-downgrades|--add-architecture|dpkg --add' "$state/calls"; }
readable_error() { [ "$status" -ne 0 ] && grep -q '^setup: error: .*[a-z]' <<<"$out"; }

# 1. A fresh machine: nothing installed.
new_case nothing
run
check "nothing installed: exit 0" test "$status" -eq 0
check "nothing installed: every package installed" installed_all
check "nothing installed: apt-get update, then one install" \
  bash -c '[ "$(grep -c "apt-get .*update" "$0")" -eq 1 ] && [ "$(grep -c "apt-get .*install" "$0")" -eq 1 ]' "$state/calls"
check "nothing installed: no downgrade, no foreign architecture" no_downgrade

# 2. Everything installed: no apt call at all.
new_case everything
for p in "${all[@]}"; do install "$p" 1.0-1; done
run
check "everything installed: exit 0" test "$status" -eq 0
check "everything installed: no apt-get call" test ! -s "$state/calls"
check "everything installed (no --for: all): says so" grep -q 'all [0-9]* packages for all present' <<<"$out"

# 3. Half installed: only the missing ones are installed (whole names: python3-serial is not
# python3-serial-asyncio).
new_case half
half=("${all[@]:0:$(( ${#all[@]} / 2 ))}")
for p in "${half[@]}"; do install "$p" 1.0-1; done
run
check "half installed: exit 0" test "$status" -eq 0
check "half installed: every package installed" installed_all
check "half installed: installs none of the installed ones" \
  bash -c 'line="$(grep "apt-get .*install" "$0")"; for p in "${@:1}"; do tr " " "\n" <<<"${line#*--no-install-recommends}" | grep -qxF -- "$p" && exit 1; done; exit 0' "$state/calls" "${half[@]}"

# 4. apt-get update fails for one architecture's index; every package still offered.
new_case update-fails
printf '%s\n' "Err:4 http://deb.debian.org/debian-security bookworm-security/main armhf Packages" \
  "E: Failed to fetch http://deb.debian.org/debian-security/dists/bookworm-security/main/binary-armhf/Packages.xz  File has unexpected size (334084 != 351124). Mirror sync in progress?" \
  "E: Some index files failed to download. They have been ignored, or old ones used instead." >"$state/update_fail"
run
check "update fails for one index: exit 0" test "$status" -eq 0
check "update fails for one index: a warning naming the failed index" grep -q 'warning: apt-get update failed.*binary-armhf/Packages' <<<"$out"
check "update fails for one index: every package installed" installed_all

# 4b. ... and a missing package is offered nowhere: a non-zero exit that names it.
new_case not-offered
cp "$work/case-update-fails/update_fail" "$state/"
grep -v '^shellcheck ' "$state/offered" >"$state/o"; mv "$state/o" "$state/offered"
run
check "package not offered: non-zero exit, one readable line" readable_error
check "package not offered: names the package and the failed update" grep -q 'error: package shellcheck is not offered.*apt-get update failed' <<<"$out"
check "package not offered: nothing installed" bash -c '! grep -q "apt-get .*install" "$0"' "$state/calls"

# 5. Not root and no sudo.
new_case no-root
echo 1000 >"$state/uid"
run
check "no root, no sudo: non-zero exit, one readable line" readable_error
check "no root, no sudo: says what to do" grep -q 'not root and sudo is not installed' <<<"$out"
check "no root, no sudo: no apt-get call" test ! -s "$state/calls"

# 6. Not root, with sudo: every apt-get call goes through sudo.
new_case sudo
echo 1000 >"$state/uid"
run with-sudo
check "sudo: exit 0" test "$status" -eq 0
check "sudo: every package installed" installed_all
check "sudo: apt-get calls, all through sudo" bash -c 'grep -q "^sudo apt-get" "$0" && ! grep -q "^apt-get" "$0"' "$state/calls"

# 7. An installed linked library older than the archive's (a security update): updated, never
#    the other way round.
new_case outdated
for p in "${all[@]}"; do install "$p" 1.0-1; done
grep -v '^libmodbus5 ' "$state/installed" >"$state/i"; mv "$state/i" "$state/installed"
install libmodbus5 3.1.6-2.1
offer libmodbus5 3.1.6-2.1+deb12u1
run
check "outdated libmodbus5: exit 0" test "$status" -eq 0
check "outdated libmodbus5: updated to the archive's newest" grep -q '^libmodbus5 3.1.6-2.1+deb12u1$' "$state/installed"
check "outdated libmodbus5: no downgrade" no_downgrade

# 7b. Installed newer than the indexes offer (an index failed): kept, nothing installed.
new_case newer
for p in "${all[@]}"; do install "$p" 1.0-1; done
grep -v '^libmodbus5 ' "$state/installed" >"$state/i"; mv "$state/i" "$state/installed"
install libmodbus5 3.1.6-2.1+deb12u1
offer libmodbus5 3.1.6-2.1
run
check "newer installed: exit 0, kept" bash -c '[ "$1" -eq 0 ] && grep -q "^libmodbus5 3.1.6-2.1+deb12u1$" "$0"' "$state/installed" "$status"
check "newer installed: no apt-get call" test ! -s "$state/calls"

# 8. apt-get install itself fails.
new_case install-fails
touch "$state/install_fail"
run
check "install fails: non-zero exit, one readable line" readable_error

# 9. Set-up by need. The demo's tier on a fresh machine: its packages and nothing else; none
#    of them a cross compiler, qemu, the kernel source or clang.
check "the demo's list names no cross compiler, qemu, kernel source or clang" \
  bash -c '! printf "%s\n" "$@" | grep -E "^(g\+\+-.*-linux-gnu|gcc-.*-linux-gnu|qemu|linux-source|clang)"' _ "${demo[@]}"
new_case demo
args=(--for demo)
run
check "--for demo, nothing installed: exit 0" test "$status" -eq 0
check "--for demo: installs exactly the demo's packages" same_set demo "${demo[@]}"
check "--for demo: none of the test or --all packages" installed_none "${test_only[@]}" "${all_only[@]}"

# 9b. The test tier after the demo's: only what the test tier adds.
new_case test-after-demo
for p in "${demo[@]}"; do install "$p" 1.0-1; done
args=(--for test)
run
check "--for test after the demo: exit 0" test "$status" -eq 0
check "--for test after the demo: installs exactly what the test tier adds" same_set test "${test_only[@]}"
check "--for test: none of the --all packages" installed_none "${all_only[@]}"

# 9c. --all after the test tier: only what --all adds; --for=all is the same option.
new_case all-after-test
for p in "${demo[@]}" "${test_only[@]}"; do install "$p" 1.0-1; done
args=(--for=all)
run
check "--for=all after the test tier: exit 0" test "$status" -eq 0
check "--for=all after the test tier: installs exactly what --all adds" same_set all "${all_only[@]}"
check "--for=all: every package installed" installed_all

# 9d. The demo's tier on a machine that has it: no apt call, whatever else is missing.
new_case demo-present
for p in "${demo[@]}"; do install "$p" 1.0-1; done
args=(--for demo)
run
check "--for demo, demo packages present: exit 0, no apt-get call" \
  bash -c '[ "$1" -eq 0 ] && [ ! -s "$0" ]' "$state/calls" "$status"
check "--for demo, demo packages present: says so" grep -q "all ${#demo[@]} packages for demo present" <<<"$out"

# 9e. An unknown tier, and --for without one: exit 2, one readable line, no apt call.
for bad in "--for nightly" "--for" "--all"; do
  new_case "bad-tier-${bad// /-}"
  read -ra args <<<"$bad"
  run
  check "'$bad': exit 2 with an error line and no apt-get call" \
    bash -c '[ "$1" -eq 2 ] && grep -q "^setup: error: " <<<"$2" && [ ! -s "$0" ]' "$state/calls" "$status" "$out"
done
args=()

echo
if [ "$failures" -ne 0 ]; then echo "setup_test: $failures check(s) failed for $script"; exit 1; fi
echo "setup_test: every check passed for $script"
