# Cross build for armhf boards (arm-linux-gnueabihf) with Debian's cross compiler (g++-arm-linux-gnueabihf). The target's
# libraries (libmodbus, libgpiod, GoogleTest, toml++, nlohmann-json, CLI11 and the C/C++
# runtime) come from a per-target sysroot of Debian armhf packages unpacked outside the build
# machine's package database (toolchain/sysroot.sh; cached in ~/.cache/mrd/sysroot/armhf/).
# MRD_SYSROOT (cache variable or environment) names one; unset, toolchain/sysroot.sh armhf is
# run to find or build it. The compiler keeps its own C library (/usr/arm-linux-gnueabihf); tests run under
# qemu-user with the sysroot as the library prefix. Preset: armhf (CMakePresets.json).
set(CMAKE_SYSTEM_NAME Linux)
set(CMAKE_SYSTEM_PROCESSOR arm)
set(CMAKE_C_COMPILER arm-linux-gnueabihf-gcc)
set(CMAKE_CXX_COMPILER arm-linux-gnueabihf-g++)
set(CMAKE_LIBRARY_ARCHITECTURE arm-linux-gnueabihf)
include(${CMAKE_CURRENT_LIST_DIR}/sysroot.cmake)
mrd_target_sysroot(armhf arm-linux-gnueabihf)
# GCC's note that std::map iterators pass differently since GCC 7.1 on 32-bit Arm (-Wpsabi):
# the whole program is built by one compiler, so it does not apply.
set(CMAKE_CXX_FLAGS_INIT -Wno-psabi)
set(CMAKE_CROSSCOMPILING_EMULATOR qemu-arm -L ${MRD_SYSROOT})
# Debian architecture of the package (CPack DEB).
set(CPACK_DEBIAN_PACKAGE_ARCHITECTURE armhf)
