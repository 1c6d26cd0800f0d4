#!/usr/bin/env bash
# Installs the Debian 12 packages the build machine needs for a task; skips what is installed.
# Idempotent. Needs root or sudo only when something is missing. Debian's archive only.
#   --for demo   build the programs and run the demo (toolchain/demo.sh): compilers, the
#                libraries the programs link, the test framework's headers (the build
#                configures the tests), gnuplot for the report's plots
#   --for test   + what the default test tier runs (toolchain/test.sh): shellcheck, ccache,
#                the Modbus interop peers (pymodbus, mbpoll), libgpiod's tools
#   --for all    + what only `toolchain/test.sh --all` and the maintainer tools need: the Arm
#                cross compilers, qemu-user, the virtual board's kernel source, QEMU and
#                initramfs tools, clang (fuzzing), clang-format (CI's style check). Default.
#
# Build-machine packages only: the Arm boards' libraries come from per-target sysroots
# (toolchain/sysroot.sh), never from multiarch packages here, so nothing here is pinned or
# downgraded to match another architecture. The libraries the programs link (libmodbus,
# libgpiod) are also brought up to the newest version the archive offers (security updates).
# Every failure prints one line, "setup: error: what failed; what to do", and exits non-zero.
set -euo pipefail
usage="Usage: toolchain/setup.sh [--for demo|test|all]   (toolchain/build.sh, demo.sh and test.sh run it)"
tier=all
while [ $# -gt 0 ]; do
  case "$1" in
    -h | --help)
      awk 'NR > 1 && !/^#/ { exit } NR > 1 { sub(/^# ?/, ""); print }' "$0"
      echo "$usage"
      exit 0
      ;;
    --for)
      [ $# -ge 2 ] || { echo "setup: error: --for needs demo, test or all ($usage)" >&2; exit 2; }
      tier="$2"
      shift 2
      ;;
    --for=*) tier="${1#*=}"; shift ;;
    *) echo "setup: error: unknown argument '$1' (try --help)" >&2; exit 2 ;;
  esac
done

# Each tier's packages; a tier installs its own and every smaller tier's.
demo_packages=(
  build-essential cmake ninja-build pkg-config python3
  libeigen3-dev libceres-dev linux-libc-dev
  libgtest-dev libgmock-dev googletest libbenchmark-dev
  libcli11-dev nlohmann-json3-dev libtomlplusplus-dev libfmt-dev libspdlog-dev
  libmodbus5 libmodbus-dev libgpiod2 libgpiod-dev
  gnuplot-nox
)
test_packages=(
  gpiod shellcheck ccache
  # Modbus interop tests: independent implementations (pymodbus, with its serial deps; mbpoll).
  python3-pymodbus python3-serial python3-serial-asyncio mbpoll
)
all_packages=(
  clang clang-format
  # Arm cross builds and their tests under qemu-user (target libraries: toolchain/sysroot.sh).
  g++-aarch64-linux-gnu g++-arm-linux-gnueabihf qemu-user
  # The virtual board: an arm64 kernel from Debian's source, QEMU, the initramfs tools.
  linux-source qemu-system-arm flex bison bc cpio
  # The Python module `import mrd` (python/, docs/python.md): its build (Python headers,
  # pybind11, numpy), its tests (pytest; pandas for the DataFrame path), the example's plots
  # (matplotlib), and `pip install` of the build into a virtual environment.
  python3-dev pybind11-dev python3-numpy python3-pytest python3-pandas python3-matplotlib
  python3-pip python3-venv python3-setuptools python3-wheel
)
case "$tier" in
  demo) packages=("${demo_packages[@]}") ;;
  test) packages=("${demo_packages[@]}" "${test_packages[@]}") ;;
  all) packages=("${demo_packages[@]}" "${test_packages[@]}" "${all_packages[@]}") ;;
  *) echo "setup: error: --for '$tier': demo, test or all ($usage)" >&2; exit 2 ;;
esac
# Runtime libraries the programs link: kept at the newest version the apt indexes offer.
linked=(libmodbus5 libgpiod2)

die() { echo "setup: error: $*" >&2; exit 1; }

# Each query sets $version and starts one process (the package tool): a tier names about a
# hundred packages, and this runs before every build.
installed_version() {  # installed version of package $1; empty when not installed
  local s
  s="$(dpkg-query -W -f='${Status} ${Version}' "$1" 2>/dev/null)" || true
  version=""
  [[ $s == "install ok installed "* ]] && version="${s#install ok installed }"
  return 0
}
candidate_version() {  # version apt would install of $1; empty when no source offers it
  local s line
  s="$(apt-cache policy "$1" 2>/dev/null)" || true
  version=""
  while IFS= read -r line; do
    [[ $line == "  Candidate: "* ]] && { version="${line#  Candidate: }"; break; }
  done <<<"$s"
  [ "$version" != "(none)" ] || version=""
}
libraries() {  # the linked libraries' installed versions, for the closing line
  local m g
  installed_version libmodbus5; m="$version"
  installed_version libgpiod2; g="$version"
  echo "libmodbus5 $m, libgpiod2 $g"
}

missing=()
for p in "${packages[@]}"; do
  installed_version "$p"
  [ -n "$version" ] || missing+=("$p")
done
# An installed linked library older than the indexes' candidate gets the update.
outdated=()
for p in "${linked[@]}"; do
  installed_version "$p"; have="$version"
  candidate_version "$p"; want="$version"
  if [ -n "$have" ] && [ -n "$want" ] && dpkg --compare-versions "$want" gt "$have"; then
    outdated+=("$p")
  fi
done

if [ ${#missing[@]} -eq 0 ] && [ ${#outdated[@]} -eq 0 ]; then
  echo "setup: all ${#packages[@]} packages for $tier present ($(libraries))"
  exit 0
fi

sudo_cmd=()
if [ "$(id -u)" -ne 0 ]; then
  command -v sudo >/dev/null 2>&1 ||
    die "${#missing[@]} packages missing (${missing[*]:0:6}...) and this is not root and sudo is not installed; run 'su -c \"bash toolchain/setup.sh --for $tier\"' once, or install sudo"
  sudo_cmd=(sudo)
fi
export DEBIAN_FRONTEND=noninteractive
apt=("${sudo_cmd[@]}" apt-get -o DPkg::Lock::Timeout=600)

# A failed index (mirror sync in progress, a stale proxy) leaves apt's previous copy in place:
# go on when every package is still offered, else say which is not and why.
update_log="$(mktemp)"
trap 'rm -f "$update_log"' EXIT
update_failed=""
if ! "${apt[@]}" update >"$update_log" 2>&1; then
  if grep -qiE 'sudo:|password|not in the sudoers|permission denied|are you root' "$update_log"; then
    die "apt-get update could not run with root rights ($(grep -m1 -iE 'sudo:|password|sudoers|permission denied|are you root' "$update_log")); run as root or give this user sudo"
  fi
  update_failed="$(grep -m1 -E '^[EW]: Failed to fetch' "$update_log" ||
                   grep -m1 -E '^(E|W|Err):' "$update_log" || echo 'exit status non-zero')"
  echo "setup: warning: apt-get update failed for some indexes ($update_failed); continuing with the indexes apt has" >&2
fi
for p in "${missing[@]}"; do
  candidate_version "$p"
  [ -n "$version" ] ||
    die "package $p is not offered by any apt source${update_failed:+ (apt-get update failed: $update_failed)}; check the network and /etc/apt/sources.list*, run 'apt-get update', then rerun"
done

if [ ${#missing[@]} -gt 0 ]; then
  echo "setup: installing for $tier: ${missing[*]}"
  "${apt[@]}" install -y -qq --no-install-recommends "${missing[@]}" ||
    die "apt-get install failed for: ${missing[*]} (see the apt output above); fix what it names, then rerun"
fi
if [ ${#outdated[@]} -gt 0 ]; then
  echo "setup: updating ${outdated[*]} to the newest version offered"
  "${apt[@]}" install -y -qq --no-install-recommends --only-upgrade "${outdated[@]}" ||
    die "apt-get could not update ${outdated[*]} (see the apt output above)"
fi
for p in "${packages[@]}"; do
  installed_version "$p"
  [ -n "$version" ] || die "$p is still not installed after apt-get install; install it by hand and rerun"
done
echo "setup: done ($(libraries))"
