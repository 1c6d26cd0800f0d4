# Cross build for armhf boards (arm-linux-gnueabihf) with Debian's cross compiler (g++-arm-linux-gnueabihf); the target's
# libraries (GoogleTest, toml++, libmodbus, libgpiod) come from Debian multiarch
# (/usr/lib/arm-linux-gnueabihf, installed by toolchain/setup.sh). Tests run under qemu-user with the
# cross sysroot as the library prefix. Preset: armhf (CMakePresets.json).
set(CMAKE_SYSTEM_NAME Linux)
set(CMAKE_SYSTEM_PROCESSOR arm)
set(CMAKE_C_COMPILER arm-linux-gnueabihf-gcc)
set(CMAKE_CXX_COMPILER arm-linux-gnueabihf-g++)
set(CMAKE_LIBRARY_ARCHITECTURE arm-linux-gnueabihf)
# Multiarch: headers in /usr/include, libraries and CMake packages in /usr/lib/arm-linux-gnueabihf.
set(CMAKE_FIND_ROOT_PATH /usr/arm-linux-gnueabihf)
set(CMAKE_FIND_ROOT_PATH_MODE_PROGRAM NEVER)
set(CMAKE_FIND_ROOT_PATH_MODE_LIBRARY BOTH)
set(CMAKE_FIND_ROOT_PATH_MODE_INCLUDE BOTH)
set(CMAKE_FIND_ROOT_PATH_MODE_PACKAGE BOTH)
# pkg-config (pkg_check_modules: libmodbus, libgpiod) reads the target's .pc files only, never
# the build machine's.
set(ENV{PKG_CONFIG_LIBDIR} /usr/lib/arm-linux-gnueabihf/pkgconfig:/usr/share/pkgconfig)
set(ENV{PKG_CONFIG_PATH} "")
set(CMAKE_CROSSCOMPILING_EMULATOR qemu-arm -L /usr/arm-linux-gnueabihf)
# Debian architecture of the package (CPack DEB).
set(CPACK_DEBIAN_PACKAGE_ARCHITECTURE armhf)
