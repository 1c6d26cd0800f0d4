# Cross build for arm64 boards (aarch64-linux-gnu) with Debian's cross compiler (g++-aarch64-linux-gnu); the target's
# libraries (GoogleTest, toml++, libmodbus, libgpiod) come from Debian multiarch
# (/usr/lib/aarch64-linux-gnu, installed by toolchain/setup.sh). Tests run under qemu-user with the
# cross sysroot as the library prefix. Preset: aarch64 (CMakePresets.json).
set(CMAKE_SYSTEM_NAME Linux)
set(CMAKE_SYSTEM_PROCESSOR aarch64)
set(CMAKE_C_COMPILER aarch64-linux-gnu-gcc)
set(CMAKE_CXX_COMPILER aarch64-linux-gnu-g++)
set(CMAKE_LIBRARY_ARCHITECTURE aarch64-linux-gnu)
# Multiarch: headers in /usr/include, libraries and CMake packages in /usr/lib/aarch64-linux-gnu.
set(CMAKE_FIND_ROOT_PATH /usr/aarch64-linux-gnu)
set(CMAKE_FIND_ROOT_PATH_MODE_PROGRAM NEVER)
set(CMAKE_FIND_ROOT_PATH_MODE_LIBRARY BOTH)
set(CMAKE_FIND_ROOT_PATH_MODE_INCLUDE BOTH)
set(CMAKE_FIND_ROOT_PATH_MODE_PACKAGE BOTH)
# pkg-config (pkg_check_modules: libmodbus, libgpiod) reads the target's .pc files only, never
# the build machine's.
set(ENV{PKG_CONFIG_LIBDIR} /usr/lib/aarch64-linux-gnu/pkgconfig:/usr/share/pkgconfig)
set(ENV{PKG_CONFIG_PATH} "")
set(CMAKE_CROSSCOMPILING_EMULATOR qemu-aarch64 -L /usr/aarch64-linux-gnu)
# Debian architecture of the package (CPack DEB).
set(CPACK_DEBIAN_PACKAGE_ARCHITECTURE arm64)
