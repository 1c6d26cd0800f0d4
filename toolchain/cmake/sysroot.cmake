# Shared part of the Arm toolchain files: find (or build, with toolchain/sysroot.sh) the
# target's sysroot and search only there and in the cross compiler's own root for libraries,
# headers and CMake packages; pkg-config reads the sysroot's .pc files only, never the build
# machine's. The sysroot's path is kept in the cache and the environment, so try_compile
# projects (which re-read this file) see the same one.
function(mrd_target_sysroot deb_arch triplet)
  if(NOT MRD_SYSROOT AND DEFINED ENV{MRD_SYSROOT})
    set(MRD_SYSROOT "$ENV{MRD_SYSROOT}")
  endif()
  if(NOT MRD_SYSROOT)
    execute_process(
      COMMAND bash "${CMAKE_CURRENT_FUNCTION_LIST_DIR}/../sysroot.sh" ${deb_arch}
      OUTPUT_VARIABLE out RESULT_VARIABLE rc OUTPUT_STRIP_TRAILING_WHITESPACE)
    if(NOT rc EQUAL 0)
      message(FATAL_ERROR "toolchain/sysroot.sh ${deb_arch} failed (its last line says why)")
    endif()
    string(REGEX REPLACE ".*\n" "" out "${out}")
    set(MRD_SYSROOT "${out}")
  endif()
  if(NOT EXISTS "${MRD_SYSROOT}/versions.txt")
    message(FATAL_ERROR "MRD_SYSROOT='${MRD_SYSROOT}' is not a sysroot of toolchain/sysroot.sh")
  endif()
  set(MRD_SYSROOT "${MRD_SYSROOT}" CACHE PATH "Target sysroot (toolchain/sysroot.sh)" FORCE)
  set(MRD_SYSROOT "${MRD_SYSROOT}" PARENT_SCOPE)
  set(ENV{MRD_SYSROOT} "${MRD_SYSROOT}")
  set(CMAKE_FIND_ROOT_PATH "${MRD_SYSROOT}" /usr/${triplet} PARENT_SCOPE)
  set(CMAKE_FIND_ROOT_PATH_MODE_PROGRAM NEVER PARENT_SCOPE)
  set(CMAKE_FIND_ROOT_PATH_MODE_LIBRARY ONLY PARENT_SCOPE)
  set(CMAKE_FIND_ROOT_PATH_MODE_INCLUDE ONLY PARENT_SCOPE)
  set(CMAKE_FIND_ROOT_PATH_MODE_PACKAGE ONLY PARENT_SCOPE)
  set(ENV{PKG_CONFIG_LIBDIR}
      "${MRD_SYSROOT}/usr/lib/${triplet}/pkgconfig:${MRD_SYSROOT}/usr/share/pkgconfig")
  set(ENV{PKG_CONFIG_SYSROOT_DIR} "${MRD_SYSROOT}")
  set(ENV{PKG_CONFIG_PATH} "")
  # The sysroot's shared libraries (libmodbus, libgpiod, toml++) resolve at link time there.
  set(CMAKE_EXE_LINKER_FLAGS_INIT "-Wl,-rpath-link,${MRD_SYSROOT}/usr/lib/${triplet}"
      PARENT_SCOPE)
endfunction()
