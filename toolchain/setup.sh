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
  # Modbus interop tests: an independent implementation (pymodbus, with its serial deps)
  python3-pymodbus python3-serial python3-serial-asyncio
)

missing=()
for p in "${packages[@]}"; do
  if ! dpkg-query -W -f='${Status}' "$p" 2>/dev/null | grep -q "install ok installed"; then
    missing+=("$p")
  fi
done

if [ ${#missing[@]} -eq 0 ]; then
  echo "setup: all ${#packages[@]} packages present"
  exit 0
fi

echo "setup: installing ${missing[*]}"
sudo_cmd=()
if [ "$(id -u)" -ne 0 ]; then
  command -v sudo >/dev/null || { echo "setup: need root or sudo to install packages" >&2; exit 1; }
  sudo_cmd=(sudo)
fi
export DEBIAN_FRONTEND=noninteractive
"${sudo_cmd[@]}" apt-get -o DPkg::Lock::Timeout=600 update -qq
"${sudo_cmd[@]}" apt-get -o DPkg::Lock::Timeout=600 install -y -qq --no-install-recommends "${missing[@]}"
