#!/usr/bin/env bash
# Builds the virtual board's initramfs (gzip'd cpio, newc): Debian's busybox-static and
# can-utils (candump) for arm64 from the arm64 sysroot (toolchain/sysroot.sh: the target's
# packages, unpacked outside the build machine's package database), the aarch64 mrd-firmware
# and mrd-hil of a cross build with every shared library they need (DT_NEEDED, walked with
# the cross readelf in the sysroot's library directories), link_up (link_up.c), the scenario
# and init.sh as /init. The sysroot is MRD_SYSROOT when set (as in the cross build's cache),
# else toolchain/sysroot.sh arm64 finds or builds it.
# Usage: toolchain/vboard/make_initramfs.sh BUILD_AARCH64_DIR SCENARIO.toml OUT.cpio.gz
set -euo pipefail
here="$(cd "$(dirname "$0")" && pwd)"
build="${1:?usage: make_initramfs.sh BUILD_AARCH64_DIR SCENARIO.toml OUT.cpio.gz}"
scenario="${2:?scenario}"
out="${3:?output}"
readelf=aarch64-linux-gnu-readelf
for exe in "$build/bin/mrd-firmware" "$build/bin/mrd-hil"; do
  [ -x "$exe" ] || { echo "make_initramfs: $exe missing (cmake --build --preset aarch64)" >&2; exit 1; }
  "$readelf" -h "$exe" | grep -q 'AArch64' || { echo "make_initramfs: $exe is not AArch64" >&2; exit 1; }
done
sysroot="${MRD_SYSROOT:-$(sed -n 's/^MRD_SYSROOT:PATH=//p' "$build/CMakeCache.txt" 2>/dev/null || true)}"
[ -n "$sysroot" ] || sysroot="$(bash "$here/../sysroot.sh" arm64 | tail -n 1)"
[ -f "$sysroot/versions.txt" ] || { echo "make_initramfs: $sysroot is not an arm64 sysroot (toolchain/sysroot.sh arm64)" >&2; exit 1; }
echo "make_initramfs: sysroot $sysroot ($(grep -E '^(libc6|libmodbus5|libgpiod2)=' "$sysroot/versions.txt" | tr '\n' ' '))" >&2
libdirs=("$sysroot/lib/aarch64-linux-gnu" "$sysroot/usr/lib/aarch64-linux-gnu" "$sysroot/lib")

root="$(mktemp -d)"
trap 'rm -rf "$root"' EXIT
mkdir -p "$root"/{bin,lib,proc,sys,dev,tmp,run,vboard}
cp "$sysroot/bin/busybox" "$root/bin/busybox"
ln -s busybox "$root/bin/sh"
cp "$sysroot/usr/bin/candump" "$root/bin/candump"
cp "$build/bin/mrd-firmware" "$build/bin/mrd-hil" "$root/bin/"
# busybox's `ip link set up` needs INET, which the board's kernel leaves out: link_up.c.
aarch64-linux-gnu-gcc -O2 -Wall -Wextra -Werror -o "$root/bin/link_up" "$here/link_up.c"
aarch64-linux-gnu-strip "$root/bin/mrd-firmware" "$root/bin/mrd-hil"
cp "$scenario" "$root/vboard/scenario.toml"
cp "$here/init.sh" "$root/init"
chmod 755 "$root/init"

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
echo "make_initramfs: libraries: ${!seen[*]}" >&2
mkdir -p "$(dirname "$out")"
(cd "$root" && find . | LC_ALL=C sort | cpio -o -H newc --owner=0:0 --quiet) | gzip -6 > "$out.tmp"
mv "$out.tmp" "$out"
echo "make_initramfs: $out ($(du -k "$out" | cut -f1) KiB)" >&2
