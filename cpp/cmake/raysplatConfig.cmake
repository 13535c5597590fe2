# CMake package of raysplat's C++ API: the IMPORTED static library raysplat::raysplat.
#
#   find_package(raysplat REQUIRED)     # -Draysplat_DIR=<repo>/cpp/cmake, or add <repo>/cpp to
#                                       # CMAKE_PREFIX_PATH
#   target_link_libraries(app PRIVATE raysplat::raysplat)
#
# add_subdirectory(<repo>/cpp) includes this file as well.
#
# The library is built by cargo, not by CMake: run `cargo build --release` in the repository first.
# Cargo's build script (build.rs, cxx_bridge) writes target/<profile>/raysplat-link.txt, which names
# the static library, the generated cxx header directory and the native libraries to link; this file
# only reads it. Inputs (variables, or environment variables of the same name):
#   RAYSPLAT_TARGET_DIR  cargo's target directory (default: $CARGO_TARGET_DIR, else <repo>/target)
#   RAYSPLAT_PROFILE     cargo profile directory (default: release; "debug" for `cargo build`)
# Outputs: raysplat_FOUND, raysplat_VERSION, RAYSPLAT_LINK_FILE, RAYSPLAT_STATIC_LIBRARY,
#   RAYSPLAT_INCLUDE_DIRS, RAYSPLAT_LIBRARY_DIRS, RAYSPLAT_LINK_LIBRARIES (the full link line after
#   the static library: shared-library paths and system library names).

if(TARGET raysplat::raysplat)
  set(raysplat_FOUND TRUE)
  return()
endif()

get_filename_component(RAYSPLAT_ROOT "${CMAKE_CURRENT_LIST_DIR}/../.." ABSOLUTE)

if(NOT RAYSPLAT_TARGET_DIR)
  if(DEFINED ENV{RAYSPLAT_TARGET_DIR})
    set(RAYSPLAT_TARGET_DIR "$ENV{RAYSPLAT_TARGET_DIR}")
  elseif(DEFINED ENV{CARGO_TARGET_DIR})
    set(RAYSPLAT_TARGET_DIR "$ENV{CARGO_TARGET_DIR}")
  else()
    set(RAYSPLAT_TARGET_DIR "${RAYSPLAT_ROOT}/target")
  endif()
endif()
get_filename_component(RAYSPLAT_TARGET_DIR "${RAYSPLAT_TARGET_DIR}" ABSOLUTE BASE_DIR "${RAYSPLAT_ROOT}")
if(NOT RAYSPLAT_PROFILE)
  if(DEFINED ENV{RAYSPLAT_PROFILE})
    set(RAYSPLAT_PROFILE "$ENV{RAYSPLAT_PROFILE}")
  else()
    set(RAYSPLAT_PROFILE release)
  endif()
endif()

set(RAYSPLAT_LINK_FILE "${RAYSPLAT_TARGET_DIR}/${RAYSPLAT_PROFILE}/raysplat-link.txt")

macro(_raysplat_not_found message)
  set(raysplat_FOUND FALSE)
  set(raysplat_NOT_FOUND_MESSAGE "${message}")
  if(raysplat_FIND_REQUIRED)
    message(FATAL_ERROR "${message}")
  elseif(NOT raysplat_FIND_QUIETLY)
    message(WARNING "${message}")
  endif()
  return()
endmacro()

if(NOT EXISTS "${RAYSPLAT_LINK_FILE}")
  set(_raysplat_cargo "cargo build --release")
  if(NOT RAYSPLAT_PROFILE STREQUAL "release")
    set(_raysplat_cargo "cargo build (profile ${RAYSPLAT_PROFILE})")
  endif()
  _raysplat_not_found("raysplat: ${RAYSPLAT_LINK_FILE} does not exist: run `${_raysplat_cargo}` in ${RAYSPLAT_ROOT} first (or set RAYSPLAT_TARGET_DIR / RAYSPLAT_PROFILE)")
endif()

file(READ "${RAYSPLAT_LINK_FILE}" _raysplat_text)
# Values are ;-separated lists, which is what CMake lists are.
function(_raysplat_field key out)
  if(_raysplat_text MATCHES "(^|\n)${key}=([^\n]*)")
    set(${out} "${CMAKE_MATCH_2}" PARENT_SCOPE)
  else()
    set(${out} "" PARENT_SCOPE)
  endif()
endfunction()
_raysplat_field(version raysplat_VERSION)
_raysplat_field(static_lib RAYSPLAT_STATIC_LIBRARY)
_raysplat_field(include_dirs RAYSPLAT_INCLUDE_DIRS)
_raysplat_field(lib_dirs RAYSPLAT_LIBRARY_DIRS)
_raysplat_field(bundled_libs _raysplat_bundled)
_raysplat_field(system_libs _raysplat_system)

get_filename_component(_raysplat_lib_dir "${RAYSPLAT_STATIC_LIBRARY}" DIRECTORY)
get_filename_component(_raysplat_link_dir "${RAYSPLAT_LINK_FILE}" DIRECTORY)
if(NOT _raysplat_lib_dir STREQUAL _raysplat_link_dir)
  # A target directory copied or moved since cargo wrote the file: cargo does not rerun build.rs.
  message(WARNING "raysplat: ${RAYSPLAT_LINK_FILE} describes ${_raysplat_lib_dir}, not its own directory; "
                  "run `touch build.rs && cargo build --release` in ${RAYSPLAT_ROOT} to refresh it")
endif()
if(NOT EXISTS "${RAYSPLAT_STATIC_LIBRARY}")
  _raysplat_not_found("raysplat: ${RAYSPLAT_STATIC_LIBRARY} does not exist: run `cargo build --release` in ${RAYSPLAT_ROOT} (the [lib] crate-type must include \"staticlib\")")
endif()
foreach(_dir IN LISTS RAYSPLAT_INCLUDE_DIRS)
  if(NOT IS_DIRECTORY "${_dir}")
    _raysplat_not_found("raysplat: include directory ${_dir} does not exist: rebuild with cargo")
  endif()
endforeach()

# Shared libraries built by openexr-sys: full paths, so that CMake also sets the build-tree run-path.
set(RAYSPLAT_LINK_LIBRARIES "")
foreach(_lib IN LISTS _raysplat_bundled)
  set(_found "")
  foreach(_dir IN LISTS RAYSPLAT_LIBRARY_DIRS)
    if(NOT _found AND EXISTS "${_dir}/${CMAKE_SHARED_LIBRARY_PREFIX}${_lib}${CMAKE_SHARED_LIBRARY_SUFFIX}")
      set(_found "${_dir}/${CMAKE_SHARED_LIBRARY_PREFIX}${_lib}${CMAKE_SHARED_LIBRARY_SUFFIX}")
    endif()
  endforeach()
  if(NOT _found)
    find_library(RAYSPLAT_${_lib}_LIBRARY NAMES ${_lib})
    set(_found "${RAYSPLAT_${_lib}_LIBRARY}")
  endif()
  if(NOT _found)
    _raysplat_not_found("raysplat: lib${_lib} not found in ${RAYSPLAT_LIBRARY_DIRS} (built by openexr-sys during `cargo build`)")
  endif()
  list(APPEND RAYSPLAT_LINK_LIBRARIES "${_found}")
endforeach()

# System libraries: Embree by path (so a missing package is reported here), the rest by name.
foreach(_lib IN LISTS _raysplat_system)
  if(_lib STREQUAL "embree3")
    find_library(RAYSPLAT_EMBREE3_LIBRARY NAMES embree3)
    if(NOT RAYSPLAT_EMBREE3_LIBRARY)
      _raysplat_not_found("raysplat: libembree3 not found (apt-get install libembree-dev)")
    endif()
    list(APPEND RAYSPLAT_LINK_LIBRARIES "${RAYSPLAT_EMBREE3_LIBRARY}")
  else()
    list(APPEND RAYSPLAT_LINK_LIBRARIES "${_lib}")
  endif()
endforeach()

set(_raysplat_rpath "")
foreach(_dir IN LISTS RAYSPLAT_LIBRARY_DIRS)
  list(APPEND _raysplat_rpath "LINKER:-rpath,${_dir}")
endforeach()

add_library(raysplat::raysplat STATIC IMPORTED)
set_target_properties(raysplat::raysplat PROPERTIES
  IMPORTED_LOCATION "${RAYSPLAT_STATIC_LIBRARY}"
  IMPORTED_LINK_INTERFACE_LANGUAGES "CXX"
  INTERFACE_INCLUDE_DIRECTORIES "${RAYSPLAT_INCLUDE_DIRS}"
  INTERFACE_COMPILE_FEATURES "cxx_std_17"
  INTERFACE_LINK_LIBRARIES "${RAYSPLAT_LINK_LIBRARIES}"
  INTERFACE_LINK_OPTIONS "${_raysplat_rpath}")

set(raysplat_FOUND TRUE)
if(NOT raysplat_FIND_QUIETLY AND NOT RAYSPLAT_CONFIG_REPORTED)
  set(RAYSPLAT_CONFIG_REPORTED TRUE)
  message(STATUS "raysplat ${raysplat_VERSION}: ${RAYSPLAT_STATIC_LIBRARY}")
endif()
