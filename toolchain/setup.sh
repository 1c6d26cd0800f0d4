#!/usr/bin/env bash
# Installs every Debian 12 package the project needs; skips what is already installed.
# Idempotent. Needs root or sudo only when something is missing. Debian's archive only.
set -euo pipefail

packages=(
  build-essential cmake ninja-build pkg-config clang
  libeigen3-dev gpiod linux-libc-dev
  libgtest-dev libgmock-dev googletest libbenchmark-dev
  libcli11-dev nlohmann-json3-dev libtomlplusplus-dev libfmt-dev libspdlog-dev
  gnuplot-nox
  # Issue 11: Arm cross builds (arm64, armhf) and their tests under qemu-user; target
  # libraries from Debian multiarch.
  g++-aarch64-linux-gnu g++-arm-linux-gnueabihf qemu-user
  libgtest-dev:arm64 libgmock-dev:arm64 libtomlplusplus-dev:arm64
  libgtest-dev:armhf libgmock-dev:armhf libtomlplusplus-dev:armhf
  # Modbus interop tests: an independent implementation (pymodbus, with its serial deps)
  python3-pymodbus python3-serial python3-serial-asyncio
  # Issue 12, the virtual board: an arm64 kernel from Debian's source, QEMU, the initramfs
  # (busybox-static and can-utils for arm64 are fetched with apt-get download, not installed).
  linux-source qemu-system-arm flex bison bc cpio
)
# The libraries the firmware links (libmodbus, libgpiod), for the build machine and both boards:
# one group per library, the runtime library first. They are Multi-Arch: same, and dpkg installs
# such a package at ONE version on every architecture, so each group is installed at the newest
# version the apt indexes offer for all three architectures. A security update whose index could
# not be fetched for one architecture then cannot make the group uninstallable: the group stays
# at (or goes back to) the version all architectures have, and a later run of this script
# (indexes complete again) moves every architecture forward together. README, "Cross builds".
native_arch="$(dpkg --print-architecture)"
matched_archs=("$native_arch" arm64 armhf)
matched_groups=("libmodbus5 libmodbus-dev" "libgpiod2 libgpiod-dev")

foreign="$(dpkg --print-foreign-architectures)"
for arch in arm64 armhf; do
  if ! grep -qx "$arch" <<<"$foreign"; then
    [ "$(id -u)" -eq 0 ] && dpkg --add-architecture "$arch" || sudo dpkg --add-architecture "$arch"
  fi
done

installed_version() {  # installed version of package[:arch]; empty when not installed
  dpkg-query -W -f='${Status} ${Version}' "$1" 2>/dev/null | sed -n 's/^install ok installed //p'
}

missing=()
for p in "${packages[@]}"; do
  [ -n "$(installed_version "$p")" ] || missing+=("$p")
done

# True when every package of the group is installed on every architecture at one version.
group_ok() {
  local p a want
  want="$(installed_version "${1%% *}:$native_arch")"
  [ -n "$want" ] || return 1
  for p in $1; do
    for a in "${matched_archs[@]}"; do
      [ "$(installed_version "$p:$a")" = "$want" ] || return 1
    done
  done
}

offered() {  # versions of package:arch in the apt indexes, one per line
  apt-cache madison "$1" | awk -F'|' '{gsub(/ /, "", $2); print $2}'
}

# Newest version offered for every package of the group on every architecture.
common_version() {
  local v p a best=""
  for v in $(offered "${1%% *}:$native_arch"); do
    for p in $1; do
      for a in "${matched_archs[@]}"; do
        offered "$p:$a" | grep -qxF "$v" || continue 3
      done
    done
    if [ -z "$best" ] || dpkg --compare-versions "$v" gt "$best"; then best="$v"; fi
  done
  [ -n "$best" ] && echo "$best"
}

unmatched=()
for g in "${matched_groups[@]}"; do group_ok "$g" || unmatched+=("$g"); done

if [ ${#missing[@]} -eq 0 ] && [ ${#unmatched[@]} -eq 0 ]; then
  versions=()
  for g in "${matched_groups[@]}"; do versions+=("${g%% *} $(installed_version "${g%% *}:$native_arch")"); done
  echo "setup: all ${#packages[@]} packages present; on ${matched_archs[*]}: ${versions[0]}, ${versions[1]}"
  exit 0
fi

sudo_cmd=()
if [ "$(id -u)" -ne 0 ]; then
  command -v sudo >/dev/null || { echo "setup: need root or sudo to install packages" >&2; exit 1; }
  sudo_cmd=(sudo)
fi
export DEBIAN_FRONTEND=noninteractive
apt=("${sudo_cmd[@]}" apt-get -o DPkg::Lock::Timeout=600)
# A failing index of one architecture (mirror sync in progress, a stale proxy) must not stop the
# set-up: apt then keeps that repository's previous indexes, for every architecture (the
# repository is updated all or nothing), and the version matching copes with what they offer.
"${apt[@]}" update -qq ||
  echo "setup: warning: apt-get update reported errors; continuing with the indexes it has" >&2
if [ ${#missing[@]} -gt 0 ]; then
  echo "setup: installing ${missing[*]}"
  "${apt[@]}" install -y -qq --no-install-recommends "${missing[@]}"
fi
for g in "${unmatched[@]}"; do
  group_ok "$g" && continue
  version="$(common_version "$g")" || {
    echo "setup: no version of $g is offered for all of ${matched_archs[*]} (apt-cache madison)" >&2
    exit 1
  }
  native_version="$(installed_version "${g%% *}:$native_arch")"
  if [ -n "$native_version" ] && dpkg --compare-versions "$native_version" gt "$version"; then
    echo "setup: warning: ${g%% *}:$native_arch $native_version has no counterpart for every" \
         "architecture in the indexes; installing $version on ${matched_archs[*]} (a downgrade" \
         "of $native_arch; rerun when apt-get update fetches every index)" >&2
  fi
  specs=()
  for p in $g; do
    for a in "${matched_archs[@]}"; do specs+=("$p:$a=$version"); done
  done
  echo "setup: installing ${specs[*]}"
  "${apt[@]}" install -y -qq --no-install-recommends --allow-downgrades "${specs[@]}"
  group_ok "$g" || { echo "setup: $g not at $version on every architecture" >&2; exit 1; }
done
