#!/usr/bin/env bash
# Installs every Debian 12 package the project needs; skips what is already installed.
# Idempotent. Needs root or sudo only when something is missing. Debian's archive only.
set -euo pipefail

packages=(
  build-essential cmake ninja-build pkg-config clang
  libeigen3-dev libmodbus-dev libgpiod-dev gpiod linux-libc-dev
  libgtest-dev libgmock-dev googletest libbenchmark-dev
  libcli11-dev nlohmann-json3-dev libtomlplusplus-dev libfmt-dev libspdlog-dev
  gnuplot-nox
  # Issue 11: Arm cross builds (arm64, armhf) and their tests under qemu-user; target
  # libraries from Debian multiarch.
  g++-aarch64-linux-gnu g++-arm-linux-gnueabihf qemu-user
  libgtest-dev:arm64 libgmock-dev:arm64 libtomlplusplus-dev:arm64 libgpiod-dev:arm64
  libgtest-dev:armhf libgmock-dev:armhf libtomlplusplus-dev:armhf libgpiod-dev:armhf
  # Modbus interop tests: an independent implementation (pymodbus, with its serial deps)
  python3-pymodbus python3-serial python3-serial-asyncio
)
# Best effort: libmodbus-dev:ARCH must match the build machine's libmodbus version
# (Multi-Arch: same); when the mirror's security index for an Arm architecture is missing, the
# versions differ and apt refuses. Nothing links libmodbus on Arm yet (fieldbus issue).
optional=(libmodbus-dev:arm64 libmodbus-dev:armhf)

foreign="$(dpkg --print-foreign-architectures)"
for arch in arm64 armhf; do
  if ! grep -qx "$arch" <<<"$foreign"; then
    [ "$(id -u)" -eq 0 ] && dpkg --add-architecture "$arch" || sudo dpkg --add-architecture "$arch"
  fi
done

missing=()
for p in "${packages[@]}"; do
  if ! dpkg-query -W -f='${Status}' "$p" 2>/dev/null | grep -q "install ok installed"; then
    missing+=("$p")
  fi
done

missing_optional=()
for p in "${optional[@]}"; do
  if ! dpkg-query -W -f='${Status}' "$p" 2>/dev/null | grep -q "install ok installed"; then
    missing_optional+=("$p")
  fi
done

# The optional ones are tried only together with a required install (keeps the fast path fast).
if [ ${#missing[@]} -eq 0 ]; then
  echo "setup: all ${#packages[@]} packages present${missing_optional[*]:+ (optional missing: ${missing_optional[*]})}"
  exit 0
fi

echo "setup: installing ${missing[*]}"
sudo_cmd=()
if [ "$(id -u)" -ne 0 ]; then
  command -v sudo >/dev/null || { echo "setup: need root or sudo to install packages" >&2; exit 1; }
  sudo_cmd=(sudo)
fi
export DEBIAN_FRONTEND=noninteractive
# A failing index of one architecture (mirror sync) must not stop the set-up.
"${sudo_cmd[@]}" apt-get -o DPkg::Lock::Timeout=600 update -qq ||
  echo "setup: warning: apt-get update reported errors; continuing with the indexes it has" >&2
if [ ${#missing[@]} -gt 0 ]; then
  "${sudo_cmd[@]}" apt-get -o DPkg::Lock::Timeout=600 install -y -qq --no-install-recommends "${missing[@]}"
fi
for p in "${missing_optional[@]}"; do
  "${sudo_cmd[@]}" apt-get -o DPkg::Lock::Timeout=600 install -y -qq --no-install-recommends "$p" \
    >/dev/null 2>&1 || echo "setup: warning: $p not installable (version skew with the build machine)" >&2
done
