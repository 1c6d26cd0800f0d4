#!/usr/bin/env bash
# Cross-builds the virtual board's arm64 kernel Image from Debian's linux-source package:
# tinyconfig + kernel.config (merge_config.sh), then `make Image`. Every symbol of the
# fragment must survive the merge (exit 1 otherwise). The Image is cached outside the clone in
# ${MRD_CACHE_DIR:-$HOME/.cache/mrd}/vboard/<key>/Image, key = sha256 of the fragment, the
# linux-source package version and this script; a cached Image is reused as is.
# Prints the Image's path on stdout (last line), progress and the time taken on stderr.
# Usage: toolchain/vboard/build_kernel.sh [-j N]
set -euo pipefail
here="$(cd "$(dirname "$0")" && pwd)"
jobs=2
[ "${1:-}" = "-j" ] && jobs="${2:?-j needs a number}"
start=$(date +%s)

src_pkg="$(dpkg-query -W -f='${Package}\n' 'linux-source-*' 2>/dev/null | grep -E '^linux-source-[0-9.]+$' | sort -V | tail -1)"
[ -n "$src_pkg" ] || { echo "build_kernel: linux-source not installed (toolchain/setup.sh)" >&2; exit 1; }
src_version="$(dpkg-query -W -f='${Version}' "$src_pkg")"
tarball="/usr/src/$src_pkg.tar.xz"
[ -f "$tarball" ] || { echo "build_kernel: $tarball missing" >&2; exit 1; }

key="$( { cat "$here/kernel.config"; echo "$src_pkg $src_version"; cat "$0"; } | sha256sum | cut -c1-16)"
cache="${MRD_CACHE_DIR:-$HOME/.cache/mrd}/vboard/$key"
if [ -f "$cache/Image" ]; then
  echo "build_kernel: cached $cache/Image ($src_pkg $src_version), $(( $(date +%s) - start )) s" >&2
  echo "$cache/Image"
  exit 0
fi

mkdir -p "$cache"
work="$(mktemp -d "$cache/work.XXXXXX")"
trap 'rm -rf "$work"' EXIT
echo "build_kernel: extracting $tarball into $work" >&2
tar -xJf "$tarball" -C "$work"
cd "$work/$src_pkg"
kmake=(make -s ARCH=arm64 CROSS_COMPILE=aarch64-linux-gnu- -j"$jobs")
"${kmake[@]}" tinyconfig >&2
scripts/kconfig/merge_config.sh -m .config "$here/kernel.config" >&2
"${kmake[@]}" olddefconfig >&2
# Every wanted symbol must have survived (a missing dependency silently drops it).
missing=0
while IFS= read -r line; do
  case "$line" in CONFIG_*=*) ;; *) continue ;; esac
  grep -qxF "$line" .config || { echo "build_kernel: $line did not survive: $(grep "^${line%%=*}=\|# ${line%%=*} " .config || echo absent)" >&2; missing=1; }
done < "$here/kernel.config"
[ "$missing" -eq 0 ] || exit 1
echo "build_kernel: building Image with -j$jobs" >&2
"${kmake[@]}" Image >&2
cp .config "$cache/config"
cp arch/arm64/boot/Image "$cache/Image.tmp" && mv "$cache/Image.tmp" "$cache/Image"
echo "build_kernel: built $cache/Image ($src_pkg $src_version) in $(( $(date +%s) - start )) s" >&2
echo "$cache/Image"
