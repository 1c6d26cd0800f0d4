# Cross build for arm64 boards (aarch64-linux-gnu) with Debian's cross compiler (g++-aarch64-linux-gnu). The target's
# libraries (libmodbus, libgpiod, GoogleTest, toml++, nlohmann-json, CLI11 and the C/C++
# runtime) come from a per-target sysroot of Debian arm64 packages unpacked outside the build
# machine's package database (toolchain/sysroot.sh; cached in ~/.cache/mrd/sysroot/arm64/).
# MRD_SYSROOT (cache variable or environment) names one; unset, toolchain/sysroot.sh arm64 is
# run to find or build it. The compiler keeps its own C library (/usr/aarch64-linux-gnu); tests run under
# qemu-user with the sysroot as the library prefix. Preset: aarch64 (CMakePresets.json).
set(CMAKE_SYSTEM_NAME Linux)
set(CMAKE_SYSTEM_PROCESSOR aarch64)
set(CMAKE_C_COMPILER aarch64-linux-gnu-gcc)
set(CMAKE_CXX_COMPILER aarch64-linux-gnu-g++)
set(CMAKE_LIBRARY_ARCHITECTURE aarch64-linux-gnu)
include(${CMAKE_CURRENT_LIST_DIR}/sysroot.cmake)
mrd_target_sysroot(arm64 aarch64-linux-gnu)
set(CMAKE_CROSSCOMPILING_EMULATOR qemu-aarch64 -L ${MRD_SYSROOT})
# Debian architecture of the package (CPack DEB).
set(CPACK_DEBIAN_PACKAGE_ARCHITECTURE arm64)
