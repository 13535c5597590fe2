# Install raysplat into a prefix that can be moved as a whole (docs/cpp.md, "Installing"):
#
#   cargo build --release && cmake -DPREFIX=<prefix> -P cpp/cmake/install.cmake   (= make install)
#
#   bin/raysplat                       the command line
#   lib/libraysplat.so(.0.1, .0.1.0)   the C++ API as a shared library exporting only the API
#   lib/libraysplat.a                  the same as a static library
#   lib/raysplat/                      private shared libraries: OpenEXR 3.0 / Imath 3.0 (built by
#                                      openexr-sys) and, when the build has it, Open Image Denoise
#                                      with its CPU device and TBB; never zlib (the system's serves)
#   include/raysplat/                  raysplat.hpp, progress.hpp, src/ffi/bridge.rs.h, rust/cxx.h
#   lib/cmake/raysplat/                raysplatConfig.cmake, raysplatConfigVersion.cmake
#   lib/pkgconfig/                     raysplat.pc (shared), raysplat-static.pc
#   share/raysplat/requirements.txt    the converter's Python requirement (usd-core)
#
# Every run-path is $ORIGIN-relative and the package files locate the prefix from their own
# position, so nothing installed names the source tree or cargo's target directory. The USD
# converter is embedded in the library and the binary; it needs only a Python with usd-core.
#
# Inputs (-D or environment): PREFIX (required), RAYSPLAT_TARGET_DIR (default $CARGO_TARGET_DIR,
# else <repo>/target), RAYSPLAT_PROFILE (default release), RAYSPLAT_STRIP (default ON: remove
# debug information: the static library has 37 MiB without, 115 MiB with it), CXX (default c++).
cmake_minimum_required(VERSION 3.21) # file(RPATH_SET)

if(NOT PREFIX)
  message(FATAL_ERROR "install.cmake: give the prefix: cmake -DPREFIX=<dir> -P cpp/cmake/install.cmake")
endif()
get_filename_component(PREFIX "${PREFIX}" ABSOLUTE)
get_filename_component(_root "${CMAKE_CURRENT_LIST_DIR}/../.." ABSOLUTE)
foreach(_var RAYSPLAT_TARGET_DIR RAYSPLAT_PROFILE RAYSPLAT_STRIP CXX)
  if(NOT DEFINED ${_var} AND DEFINED ENV{${_var}})
    set(${_var} "$ENV{${_var}}")
  endif()
endforeach()
if(NOT RAYSPLAT_TARGET_DIR)
  set(RAYSPLAT_TARGET_DIR "$ENV{CARGO_TARGET_DIR}")
  if(NOT RAYSPLAT_TARGET_DIR)
    set(RAYSPLAT_TARGET_DIR "${_root}/target")
  endif()
endif()
if(NOT RAYSPLAT_PROFILE)
  set(RAYSPLAT_PROFILE release)
endif()
if(NOT DEFINED RAYSPLAT_STRIP)
  set(RAYSPLAT_STRIP ON)
endif()
if(NOT CXX)
  set(CXX c++)
endif()
set(_out "${RAYSPLAT_TARGET_DIR}/${RAYSPLAT_PROFILE}")

# ---- what cargo built: the link description written by build.rs (cxx_bridge) ------------------
set(_link_file "${_out}/raysplat-link.txt")
if(NOT EXISTS "${_link_file}")
  message(FATAL_ERROR "install.cmake: ${_link_file} does not exist: run `cargo build --release` in ${_root} first")
endif()
file(READ "${_link_file}" _text)
function(_field key out)
  if(_text MATCHES "(^|\n)${key}=([^\n]*)")
    set(${out} "${CMAKE_MATCH_2}" PARENT_SCOPE)
  else()
    set(${out} "" PARENT_SCOPE)
  endif()
endfunction()
_field(version _version)
_field(static_lib _static)
_field(lib_dirs _lib_dirs)
_field(bundled_libs _bundled)
_field(system_libs _system)
string(REGEX MATCH "^([0-9]+)\\.([0-9]+)" _ "${_version}")
set(_abi "${CMAKE_MATCH_1}.${CMAKE_MATCH_2}") # 0.x: a new minor version is a new ABI
foreach(_f "${_static}" "${_out}/raysplat" "${_out}/raysplat-cxx/include/rust/cxx.h")
  if(NOT EXISTS "${_f}")
    message(FATAL_ERROR "install.cmake: ${_f} does not exist: run `cargo build --release` in ${_root}")
  endif()
endforeach()

function(_run)
  execute_process(COMMAND ${ARGN} RESULT_VARIABLE _rc OUTPUT_VARIABLE _o ERROR_VARIABLE _e)
  if(NOT _rc EQUAL 0)
    list(JOIN ARGN " " _cmd)
    message(FATAL_ERROR "install.cmake: `${_cmd}` failed (${_rc}):\n${_o}${_e}")
  endif()
  set(_run_output "${_o}" PARENT_SCOPE)
endfunction()

set(_lib "${PREFIX}/lib")
set(_private "${_lib}/raysplat")
set(_include "${PREFIX}/include/raysplat")
file(REMOVE_RECURSE "${_private}" "${_include}" "${_lib}/cmake/raysplat")
file(GLOB _old "${_lib}/libraysplat.so*")
if(_old)
  file(REMOVE ${_old})
endif()
file(MAKE_DIRECTORY "${PREFIX}/bin" "${_private}" "${_include}" "${_lib}/cmake/raysplat"
     "${_lib}/pkgconfig" "${PREFIX}/share/raysplat")

# ---- private shared libraries ------------------------------------------------------------------
# Each is copied under its SONAME with a run-path of $ORIGIN, with the libraries it needs that lie
# beside it, except zlib and TBB: the system has them (zlib1g; libtbb12, which Embree 3 needs, so
# it is loaded before Open Image Denoise's device anyway), and a private libz.so.1 or libtbb.so.12
# would shadow the program's own wherever lib/raysplat is on its run-path (the static library).
function(_soname file out)
  _run(readelf -d "${file}")
  if(_run_output MATCHES "Library soname: \\[([^]]+)\\]")
    set(${out} "${CMAKE_MATCH_1}" PARENT_SCOPE)
  else()
    get_filename_component(_n "${file}" NAME)
    set(${out} "${_n}" PARENT_SCOPE)
  endif()
endfunction()
set(_copied "")
function(_copy_private src_dir name)
  if(name MATCHES "^lib(z|tbb)\\.so" OR name IN_LIST _copied)
    return()
  endif()
  get_filename_component(_real "${src_dir}/${name}" REALPATH)
  _soname("${_real}" _so)
  if(NOT EXISTS "${_private}/${_so}")
    file(COPY_FILE "${_real}" "${_private}/${_so}")
    unset(_rp) # (a recursive call sees its caller's variables)
    unset(_rup)
    file(READ_ELF "${_private}/${_so}" RPATH _rp RUNPATH _rup)
    if(_rp OR _rup)
      file(RPATH_SET FILE "${_private}/${_so}" NEW_RPATH "\$ORIGIN")
    endif()
  endif()
  if(NOT name STREQUAL _so AND NOT EXISTS "${_private}/${name}")
    file(CREATE_LINK "${_so}" "${_private}/${name}" SYMBOLIC)
  endif()
  list(APPEND _copied "${name}")
  set(_copied "${_copied}" PARENT_SCOPE)
  _run(readelf -d "${_real}")
  string(REGEX MATCHALL "Shared library: \\[[^]]+\\]" _needed "${_run_output}")
  foreach(_n IN LISTS _needed)
    string(REGEX REPLACE "Shared library: \\[([^]]+)\\]" "\\1" _n "${_n}")
    if(EXISTS "${src_dir}/${_n}")
      _copy_private("${src_dir}" "${_n}")
      set(_copied "${_copied}" PARENT_SCOPE)
    endif()
  endforeach()
endfunction()

set(_private_link "")   # file names in lib/raysplat a static link names
set(_private_flags "")  # the same as -l flags
list(REMOVE_ITEM _bundled z)
if("embree4" IN_LIST _bundled)
  # The prefix's package files and shared library are written for the system's Embree 3.
  message(FATAL_ERROR "install.cmake: ${_out} is a build with Embree 4 (--features embree4); "
                      "install supports the Embree 3 build only (`cargo build --release` without it)")
endif()
foreach(_name IN LISTS _bundled)
  set(_found "")
  foreach(_dir IN LISTS _lib_dirs)
    if(NOT _found AND EXISTS "${_dir}/lib${_name}.so")
      set(_found "${_dir}")
    endif()
  endforeach()
  if(NOT _found)
    message(FATAL_ERROR "install.cmake: lib${_name}.so not found in ${_lib_dirs}: rebuild with cargo")
  endif()
  _copy_private("${_found}" "lib${_name}.so")
  list(APPEND _private_link "lib${_name}.so")
  list(APPEND _private_flags "-l${_name}")
  if(_name STREQUAL "OpenImageDenoise")
    # Open Image Denoise loads its CPU device by name from beside itself (GPU devices are left out).
    file(GLOB _devices RELATIVE "${_found}" "${_found}/libOpenImageDenoise_device_cpu.so*")
    foreach(_d IN LISTS _devices)
      _copy_private("${_found}" "${_d}")
    endforeach()
  endif()
endforeach()

# ---- headers -----------------------------------------------------------------------------------
file(COPY "${_root}/cpp/include/raysplat/" DESTINATION "${_include}")
file(COPY "${_out}/raysplat-cxx/include/rust/cxx.h" DESTINATION "${_include}/rust")
file(COPY "${_out}/raysplat-cxx/include/raysplat/src/ffi/bridge.rs.h" DESTINATION "${_include}/src/ffi")

# ---- the static library and the command line ---------------------------------------------------
string(TIMESTAMP _t0 "%s")
file(COPY_FILE "${_static}" "${_lib}/libraysplat.a")
file(COPY_FILE "${_out}/raysplat" "${PREFIX}/bin/raysplat")
if(RAYSPLAT_STRIP)
  _run(strip --strip-debug "${_lib}/libraysplat.a" "${PREFIX}/bin/raysplat")
endif()
file(RPATH_SET FILE "${PREFIX}/bin/raysplat" NEW_RPATH "\$ORIGIN/../lib/raysplat")

# ---- the shared library: the static one linked into a .so exporting only the API ---------------
# The API is the C++ side of the cxx bridge (namespace raysplat: the generated shims and the
# structs' operators; namespace rust: cxx's String, Vec, Slice, Box, Error, with their typeinfo
# and vtables). Rust's own symbols (legacy mangling: a trailing 17h<hash>E) stay hidden, as do
# the Rust standard library and the OpenEXR wrapper.
set(_work "${_out}/raysplat-install")
file(MAKE_DIRECTORY "${_work}")
_run(nm -g --defined-only "${_static}")
string(REGEX MATCHALL "[^\n]+" _lines "${_run_output}")
set(_exports "")
foreach(_l IN LISTS _lines)
  if(_l MATCHES " [TDRBVW] (_Z(N[KRVO]*|T[ISV]N?)(4rust|8raysplat)[^ ]*)$")
    set(_s "${CMAKE_MATCH_1}")
    if(NOT _s MATCHES "17h[0-9a-f]+E$")
      list(APPEND _exports "${_s}")
    endif()
  endif()
endforeach()
list(REMOVE_DUPLICATES _exports)
list(LENGTH _exports _n_exports)
if(_n_exports LESS 100)
  message(FATAL_ERROR "install.cmake: only ${_n_exports} API symbols in ${_static}")
endif()
list(JOIN _exports ";\n    " _map)
file(WRITE "${_work}/raysplat.map" "{\n  global:\n    ${_map};\n  local: *;\n};\n")
list(TRANSFORM _exports PREPEND "-Wl,-u,")
list(JOIN _exports "\n" _rsp)
file(WRITE "${_work}/exports.rsp" "${_rsp}\n")
set(_so_file "libraysplat.so.${_version}")
set(_so_name "libraysplat.so.${_abi}")
set(_strip_flag "")
if(RAYSPLAT_STRIP)
  set(_strip_flag "-Wl,-S")
endif()
list(REMOVE_ITEM _system embree3 c)
list(TRANSFORM _system PREPEND "-l" OUTPUT_VARIABLE _system_flags)
string(TIMESTAMP _t1 "%s")
_run("${CXX}" -shared -o "${_lib}/${_so_file}" "-Wl,-soname,${_so_name}" "@${_work}/exports.rsp"
     "-Wl,--version-script=${_work}/raysplat.map" -Wl,--gc-sections -Wl,--no-undefined ${_strip_flag}
     "${_static}" "-L${_private}" ${_private_flags} -lembree3 ${_system_flags}
     "-Wl,-rpath,\$ORIGIN/raysplat")
string(TIMESTAMP _t2 "%s")
_run(nm -D --defined-only "${_lib}/${_so_file}")
string(REGEX MATCHALL "\n" _exported "\n${_run_output}")
list(LENGTH _exported _n_exported)
math(EXPR _n_exported "${_n_exported} - 1")
file(CREATE_LINK "${_so_file}" "${_lib}/${_so_name}" SYMBOLIC)
file(CREATE_LINK "${_so_name}" "${_lib}/libraysplat.so" SYMBOLIC)

# ---- package files -----------------------------------------------------------------------------
set(RAYSPLAT_VERSION "${_version}")
set(RAYSPLAT_VERSION_MINOR "${_abi}")
set(RAYSPLAT_SHARED_FILE "${_so_file}")
set(RAYSPLAT_SONAME "${_so_name}")
list(JOIN _private_link " " RAYSPLAT_PRIVATE_LINK)
list(JOIN _system " " RAYSPLAT_SYSTEM_LIBS)
configure_file("${_root}/cpp/cmake/raysplatConfig.installed.cmake.in"
               "${_lib}/cmake/raysplat/raysplatConfig.cmake" @ONLY)
file(READ "${_root}/cpp/cmake/raysplatVersionRule.cmake" _rule)
file(WRITE "${_lib}/cmake/raysplat/raysplatConfigVersion.cmake"
     "# Version of the installed raysplat package (written by cpp/cmake/install.cmake).\nset(PACKAGE_VERSION \"${_version}\")\n${_rule}")
list(JOIN _private_flags " " RAYSPLAT_PC_PRIVATE)
list(JOIN _system_flags " " RAYSPLAT_PC_SYSTEM)
string(PREPEND RAYSPLAT_PC_SYSTEM "-lembree3 ")
configure_file("${_root}/cpp/raysplat.pc.installed.in" "${_lib}/pkgconfig/raysplat.pc" @ONLY)
configure_file("${_root}/cpp/raysplat-static.pc.installed.in" "${_lib}/pkgconfig/raysplat-static.pc" @ONLY)
file(COPY "${_root}/python/requirements.txt" DESTINATION "${PREFIX}/share/raysplat")

math(EXPR _copy_s "${_t1} - ${_t0}")
math(EXPR _link_s "${_t2} - ${_t1}")
message(STATUS "raysplat ${_version} installed into ${PREFIX} (libraysplat.so exports ${_n_exported} symbols; "
               "static library and binary copied in ${_copy_s} s, shared library linked in ${_link_s} s)")
