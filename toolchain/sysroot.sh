#!/usr/bin/env bash
# Per-target sysroot for the Arm builds: the target's Debian packages (libmodbus, libgpiod,
# GoogleTest, toml++, the C and C++ runtime, and the virtual board's busybox and candump), fetched
# with `apt-get download` through a private apt state for that architecture and unpacked with
# `dpkg-deb -x`. Nothing is installed on the build machine: no `dpkg --add-architecture`, and the
# build machine's own packages stay at the newest versions its archive offers.
#
# Cache: ${MRD_CACHE_DIR:-$HOME/.cache/mrd}/sysroot/<arch>/<key>/, key = sha256 of the
# architecture, every package=version and this script; a finished sysroot is reused as is and
# holds versions.txt (what the board image gets). Prints the sysroot's path on stdout (last
# line); progress, warnings and errors on stderr, each error one line that says what to do.
# Usage: toolchain/sysroot.sh arm64|armhf   (aarch64 is taken for arm64)
set -euo pipefail
die() { echo "sysroot: error: $*" >&2; exit 1; }

arch="${1:-}"
case "$arch" in
  arm64|aarch64) arch=arm64; triplet=aarch64-linux-gnu ;;
  armhf) triplet=arm-linux-gnueabihf ;;
  *) die "usage: toolchain/sysroot.sh arm64|armhf (got '${arch}')" ;;
esac
# Runtime libraries (also what qemu-user and the virtual board load), then the build's
# development packages, then the virtual board's tools.
packages=(
  libc6 libgcc-s1 libstdc++6 libmodbus5 libgpiod2 libtomlplusplus3
  libmodbus-dev libgpiod-dev libgtest-dev libgmock-dev libtomlplusplus-dev
  nlohmann-json3-dev libcli11-dev
  busybox-static can-utils
)
# Runtime libraries whose build-machine version is compared with the target's (security updates).
linked=(libc6 libgcc-s1 libstdc++6 libmodbus5 libgpiod2 libtomlplusplus3)

cache="${MRD_CACHE_DIR:-$HOME/.cache/mrd}"
state="$cache/apt/$arch"
mkdir -p "$state/lists/partial" "$state/archives/partial" "$state/etc"
# One run per architecture at a time (parallel tests share the cache).
exec 9>"$state/lock"
flock 9
: >"$state/status"

# The Debian repositories the build machine uses (its mirror, suites and components), for the
# target's architecture. Only Debian's archive: other repositories in the sources are skipped.
sources="$state/etc/sources.list"
# shellcheck disable=SC2016  # $(ORIGIN)... are apt's format fields, not shell expansions
apt-get indextargets --format '$(ORIGIN)|$(REPO_URI)|$(RELEASE)|$(COMPONENT)' \
    'Identifier: Packages' 2>/dev/null |
  awk -F'|' '$1 == "Debian" { print "deb " $2 " " $3 " " $4 }' | sort -u >"$sources.new" || true
[ -s "$sources.new" ] ||
  die "no Debian repository in the build machine's apt sources with fetched indexes; run 'apt-get update' (as root) and check /etc/apt/sources.list*"
mv "$sources.new" "$sources"

apt_opts=(
  -o "APT::Architecture=$arch" -o "APT::Architectures::=$arch"
  -o "Dir::Etc::SourceList=$sources" -o "Dir::Etc::SourceParts=$state/etc/none"
  -o "Dir::Etc::Preferences=$state/etc/none" -o "Dir::Etc::PreferencesParts=$state/etc/none"
  -o "Dir::State=$state" -o "Dir::State::Lists=$state/lists" -o "Dir::State::status=$state/status"
  -o "Dir::Cache=$state" -o "Dir::Cache::archives=$state/archives"
  -o "APT::Sandbox::User=$(id -un)" -o "Debug::NoLocking=1" -q
)

# Refresh the target's indexes. A failed index leaves apt's previous copy in place (or none):
# say which, and go on with what there is.
echo "sysroot: $arch: apt-get update (Debian's archive, $(wc -l <"$sources") index sets)" >&2
update_log="$state/update.log"
if ! apt-get "${apt_opts[@]}" update >"$update_log" 2>&1; then
  echo "sysroot: warning: $arch: apt-get update reported errors; using the indexes it has:" >&2
  grep -E '^(Err|E|W):' "$update_log" | sed 's/^/sysroot:   /' >&2 || true
fi
failed_indexes="$(grep -E '^(Err|W: Failed to fetch|E: Failed to fetch)' "$update_log" || true)"

candidate() {  # candidate version of a package in the target's indexes; empty when none
  apt-cache "${apt_opts[@]}" policy "$1" 2>/dev/null |
    sed -n 's/^  Candidate: //p' | grep -v '^(none)$' || true
}
pins=()
for p in "${packages[@]}"; do
  v="$(candidate "$p")"
  [ -n "$v" ] || die "$arch: package $p is not offered by the target's indexes (see $update_log); check the network and the apt sources, then rerun"
  pins+=("$p=$v")
done

# A build-machine library newer than the target's: the target's security index is stale or
# the update is not built for it yet. The board image gets the older version; say so.
for p in "${linked[@]}"; do
  native="$(dpkg-query -W -f='${Status} ${Version}' "$p" 2>/dev/null |
            sed -n 's/^install ok installed //p' || true)"
  target="$(candidate "$p")"
  if [ -n "$native" ] && dpkg --compare-versions "$native" gt "$target"; then
    echo "sysroot: warning: $arch: $p $target goes into the board image, older than the build" \
         "machine's $native: the $arch index that carries $native (a security or point update)" \
         "was not fetched or does not have it yet${failed_indexes:+ (apt-get update failed for some indexes, see $update_log)};" \
         "rerun toolchain/sysroot.sh $arch when it does" >&2
  fi
done

key="$( { echo "$arch"; printf '%s\n' "${pins[@]}"; cat "$0"; } | sha256sum | cut -c1-16)"
root="$cache/sysroot/$arch/$key"
if [ -f "$root/versions.txt" ]; then
  echo "sysroot: $arch: cached $root" >&2
  echo "$root"
  exit 0
fi

echo "sysroot: $arch: downloading ${#pins[@]} packages" >&2
debs="$state/debs"
mkdir -p "$debs"
(cd "$debs" && apt-get "${apt_opts[@]}" download "${pins[@]}" >"$state/download.log" 2>&1) ||
  die "$arch: apt-get download failed (see $state/download.log); check the network, then rerun"
mkdir -p "$cache/sysroot/$arch"
work="$(mktemp -d "$cache/sysroot/$arch/work.XXXXXX")"
trap 'rm -rf "$work"' EXIT
for pin in "${pins[@]}"; do
  p="${pin%%=*}"
  v="${pin#*=}"
  found=("$debs/${p}_${v//:/%3a}_"*.deb)
  deb="${found[0]}"
  [ -f "$deb" ] || die "$arch: $p $v was not downloaded (see $state/download.log)"
  dpkg-deb -x "$deb" "$work"
done
# Debian's libc6 ships the loader in /lib and the libraries in /lib/<triplet> (the /lib ->
# /usr/lib merge belongs to the installed system): the dev symlinks of the packages are
# relative and stay valid as unpacked.
[ -e "$work/usr/lib/$triplet/libmodbus.so" ] || die "$arch: unpacked sysroot lacks libmodbus.so"
printf '%s\n' "${pins[@]}" >"$work/versions.txt"
rm -rf "$root"
mv "$work" "$root"
trap - EXIT
# Keep this sysroot and the one before it (a build directory may still name it).
find "$cache/sysroot/$arch" -mindepth 1 -maxdepth 1 -type d ! -name 'work.*' -printf '%T@ %p\n' |
  sort -rn | tail -n +3 | cut -d' ' -f2- | while IFS= read -r old; do rm -rf "$old"; done
echo "sysroot: $arch: built $root (libmodbus5 $(candidate libmodbus5), libgpiod2 $(candidate libgpiod2))" >&2
echo "$root"
