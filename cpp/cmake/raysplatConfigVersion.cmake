# Version of the raysplat package in the source tree: the `version` of the repository's Cargo.toml
# (compatibility: raysplatVersionRule.cmake). An installed package has its own copy with the
# version written in (cpp/cmake/install.cmake).
get_filename_component(_raysplat_manifest "${CMAKE_CURRENT_LIST_DIR}/../../Cargo.toml" ABSOLUTE)
file(STRINGS "${_raysplat_manifest}" _raysplat_version_line REGEX "^version *= *\"[^\"]+\"" LIMIT_COUNT 1)
string(REGEX REPLACE "^version *= *\"([^\"]+)\".*" "\\1" PACKAGE_VERSION "${_raysplat_version_line}")
include("${CMAKE_CURRENT_LIST_DIR}/raysplatVersionRule.cmake")
