#!/usr/bin/env bash
# The fresh-machine check: the README's commands on a minimal Debian 12, as a new user runs
# them. Builds a minimal root with debootstrap (--variant=minbase bookworm, from the build
# machine's Debian mirror; cached in ${MRD_CACHE_DIR:-$HOME/.cache/mrd}/fresh/<date>/, one per
# day), copies it, clones this repository's HEAD into it, mounts /proc, /sys and /dev, and runs
# `bash toolchain/demo.sh`, then `bash toolchain/test.sh`, then `bash toolchain/test.sh --all`
# inside with chroot, each installing what its tier needs (setup.sh --for demo|test|all).
# Prints each one's exit status and wall time; the whole output goes to
# OUT_DIR/fresh_check.log. Needs root (debootstrap, mount, chroot) and about 1 h on 2 cores
# (--all builds the virtual board's kernel once inside the fresh root: its cache,
# ~/.cache/mrd, is the fresh root's). Run it before a release and after any change to
# toolchain/setup.sh, toolchain/sysroot.sh or the package lists.
# Usage: toolchain/fresh_check.sh [OUT_DIR]   (default: ./fresh-check)
set -euo pipefail
src="$(cd "$(dirname "$0")/.." && pwd)"
out="$(mkdir -p "${1:-fresh-check}" && cd "${1:-fresh-check}" && pwd)"
die() { echo "fresh_check: error: $*" >&2; exit 1; }
[ "$(id -u)" -eq 0 ] || die "needs root (debootstrap, mount, chroot); run it with sudo"
command -v debootstrap >/dev/null || die "debootstrap is not installed; apt-get install debootstrap"
git -C "$src" rev-parse HEAD >/dev/null 2>&1 || die "$src is not a git checkout"
[ -z "$(git -C "$src" status --porcelain --untracked-files=no)" ] ||
  echo "fresh_check: warning: uncommitted changes are not checked (the clone takes HEAD)" >&2

# The build machine's Debian mirror for a suite (its first index target), else Debian's own.
debian_repo() {  # debian_repo SUITE DEFAULT
  local uri
  # shellcheck disable=SC2016  # apt's format fields, not shell expansions
  uri="$(apt-get indextargets --format '$(ORIGIN) $(REPO_URI) $(RELEASE)' 'Identifier: Packages' \
           2>/dev/null | awk -v s="$1" '$1 == "Debian" && $3 == s { print $2; exit }' || true)"
  echo "${uri:-$2}"
}
mirror="$(debian_repo bookworm http://deb.debian.org/debian/)"
security="$(debian_repo bookworm-security http://deb.debian.org/debian-security/)"

cache="${MRD_CACHE_DIR:-$HOME/.cache/mrd}/fresh"
base="$cache/$(date +%Y-%m-%d)"
exec > >(tee "$out/fresh_check.log") 2>&1
echo "fresh_check: $(date -Is), $(git -C "$src" rev-parse --short HEAD), mirror $mirror"
if [ ! -f "$base/done" ]; then
  rm -rf "$base"
  mkdir -p "$base"
  t=$(date +%s)
  echo "fresh_check: debootstrap --variant=minbase bookworm into $base/root"
  debootstrap --variant=minbase bookworm "$base/root" "$mirror" >"$base/debootstrap.log" 2>&1 ||
    die "debootstrap failed (see $base/debootstrap.log)"
  touch "$base/done"
  echo "fresh_check: base root in $(( $(date +%s) - t )) s"
  find "$cache" -mindepth 1 -maxdepth 1 -type d ! -path "$base" -exec rm -rf {} +
fi

root="$(mktemp -d "$cache/run.XXXXXX")"
# shellcheck disable=SC2317  # called by the EXIT trap
cleanup() {
  for m in dev/pts dev sys proc; do
    mountpoint -q "$root/$m" && umount -l "$root/$m"
  done
  rm -rf --one-file-system "$root"
}
trap cleanup EXIT
echo "fresh_check: copying the base root"
cp -a "$base/root/." "$root/"
# What a fresh Debian 12 installation has: the main, updates and security suites; name service.
cat >"$root/etc/apt/sources.list" <<EOF
deb $mirror bookworm main
deb $mirror bookworm-updates main
deb $security bookworm-security main
EOF
cp /etc/resolv.conf "$root/etc/resolv.conf"
[ -f "$root/etc/hosts" ] || printf '127.0.0.1 localhost\n::1 localhost ip6-localhost\n' >"$root/etc/hosts"
git clone -q "$src" "$root/root/mrd"
mount -t proc proc "$root/proc"
mount -t sysfs sysfs "$root/sys"
mount --bind /dev "$root/dev"
mount --bind /dev/pts "$root/dev/pts"

status=0
for cmd in "bash toolchain/demo.sh" "bash toolchain/test.sh" "bash toolchain/test.sh --all"; do
  echo
  echo "fresh_check: == $cmd"
  t=$(date +%s)
  rc=0
  chroot "$root" /usr/bin/env -i HOME=/root TERM=dumb LANG=C.UTF-8 \
    PATH=/usr/local/sbin:/usr/local/bin:/usr/sbin:/usr/bin:/sbin:/bin \
    bash -c "cd /root/mrd && $cmd" || rc=$?
  echo "fresh_check: $cmd: exit $rc, wall $(( $(date +%s) - t )) s"
  [ "$rc" -eq 0 ] || status=1
done
echo
echo "fresh_check: in the fresh root after the three commands:"
chroot "$root" dpkg -l libmodbus5 libgpiod2 2>&1 | tail -n 2
echo "fresh_check: $([ "$status" -eq 0 ] && echo passed || echo FAILED) (log: $out/fresh_check.log)"
exit "$status"
