#!/usr/bin/env bash
# Builds the virtual board's initramfs (gzip'd cpio, newc): Debian's busybox-static and
# can-utils (candump) for arm64, extracted from the packages (apt-get download, cached in
# ${MRD_CACHE_DIR:-$HOME/.cache/mrd}/vboard/debs), the aarch64 mrd-firmware and mrd-hil of a
# cross build with every shared library they need (DT_NEEDED, walked with the cross readelf
# in the arm64 multiarch directories), link_up (link_up.c), the scenario and init.sh as /init.
# Usage: toolchain/vboard/make_initramfs.sh BUILD_AARCH64_DIR SCENARIO.toml OUT.cpio.gz
set -euo pipefail
here="$(cd "$(dirname "$0")" && pwd)"
build="${1:?usage: make_initramfs.sh BUILD_AARCH64_DIR SCENARIO.toml OUT.cpio.gz}"
scenario="${2:?scenario}"
out="${3:?output}"
readelf=aarch64-linux-gnu-readelf
libdirs=(/usr/aarch64-linux-gnu/lib /usr/lib/aarch64-linux-gnu /lib/aarch64-linux-gnu)
for exe in "$build/bin/mrd-firmware" "$build/bin/mrd-hil"; do
  [ -x "$exe" ] || { echo "make_initramfs: $exe missing (cmake --build --preset aarch64)" >&2; exit 1; }
  "$readelf" -h "$exe" | grep -q 'AArch64' || { echo "make_initramfs: $exe is not AArch64" >&2; exit 1; }
done

debs="${MRD_CACHE_DIR:-$HOME/.cache/mrd}/vboard/debs"
mkdir -p "$debs"
fetch() {  # package:arch -> path of its .deb in the cache
  local f
  f="$(ls "$debs/${1%%:*}"_*_arm64.deb 2>/dev/null | head -1 || true)"
  if [ -z "$f" ]; then
    (cd "$debs" && apt-get download -q "$1" >&2)
    f="$(ls "$debs/${1%%:*}"_*_arm64.deb | head -1)"
  fi
  echo "$f"
}

root="$(mktemp -d)"
trap 'rm -rf "$root"' EXIT
pkgs="$(mktemp -d -p "$root")"
dpkg-deb -x "$(fetch busybox-static:arm64)" "$pkgs/busybox"
dpkg-deb -x "$(fetch can-utils:arm64)" "$pkgs/can-utils"
mkdir -p "$root"/{bin,lib,proc,sys,dev,tmp,run,vboard}
cp "$pkgs/busybox/bin/busybox" "$root/bin/busybox"
ln -s busybox "$root/bin/sh"
cp "$pkgs/can-utils/usr/bin/candump" "$root/bin/candump"
cp "$build/bin/mrd-firmware" "$build/bin/mrd-hil" "$root/bin/"
# busybox's `ip link set up` needs INET, which the board's kernel leaves out: link_up.c.
aarch64-linux-gnu-gcc -O2 -Wall -Wextra -Werror -o "$root/bin/link_up" "$here/link_up.c"
aarch64-linux-gnu-strip "$root/bin/mrd-firmware" "$root/bin/mrd-hil"
cp "$scenario" "$root/vboard/scenario.toml"
cp "$here/init.sh" "$root/init"
chmod 755 "$root/init"
rm -rf "$pkgs"

find_lib() {
  local d
  for d in "${libdirs[@]}"; do
    [ -e "$d/$1" ] && { readlink -f "$d/$1"; return 0; }
  done
  echo "make_initramfs: shared library $1 not found in ${libdirs[*]}" >&2
  return 1
}
# Breadth-first over DT_NEEDED; every library lands in /lib under its soname.
queue=("$root/bin/mrd-firmware" "$root/bin/mrd-hil" "$root/bin/candump" "$root/bin/link_up"
       ld-linux-aarch64.so.1)
declare -A seen=()
while [ ${#queue[@]} -gt 0 ]; do
  item="${queue[0]}"
  queue=("${queue[@]:1}")
  if [[ "$item" != /* ]]; then
    [ -n "${seen[$item]:-}" ] && continue
    seen[$item]=1
    src="$(find_lib "$item")"
    cp "$src" "$root/lib/$item"
    item="$root/lib/$item"
  fi
  while read -r lib; do
    [ -n "${seen[$lib]:-}" ] || queue+=("$lib")
  done < <("$readelf" -d "$item" | sed -n 's/.*(NEEDED).*\[\(.*\)\]/\1/p')
done
echo "make_initramfs: libraries: $(ls "$root/lib" | tr '\n' ' ')" >&2
mkdir -p "$(dirname "$out")"
(cd "$root" && find . | LC_ALL=C sort | cpio -o -H newc --owner=0:0 --quiet) | gzip -6 > "$out.tmp"
mv "$out.tmp" "$out"
echo "make_initramfs: $out ($(du -k "$out" | cut -f1) KiB)" >&2
