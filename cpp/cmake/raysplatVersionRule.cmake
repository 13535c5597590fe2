# Compatibility rule of the raysplat package, given PACKAGE_VERSION: any 0.x version is compatible
# only with the same minor version (Cargo's rule for 0.x), 1.x and later with the same major
# version. Included by the in-tree raysplatConfigVersion.cmake and appended to the installed one.
set(PACKAGE_VERSION_COMPATIBLE FALSE)
set(PACKAGE_VERSION_EXACT FALSE)
if(NOT "${PACKAGE_FIND_VERSION}" STREQUAL "")
  string(REGEX MATCH "^([0-9]+)\\.([0-9]+)" _ "${PACKAGE_VERSION}")
  set(_major "${CMAKE_MATCH_1}")
  set(_minor "${CMAKE_MATCH_2}")
  if(NOT PACKAGE_VERSION VERSION_LESS PACKAGE_FIND_VERSION
     AND _major EQUAL PACKAGE_FIND_VERSION_MAJOR
     AND (_major GREATER 0 OR _minor EQUAL PACKAGE_FIND_VERSION_MINOR))
    set(PACKAGE_VERSION_COMPATIBLE TRUE)
  endif()
  if(PACKAGE_VERSION VERSION_EQUAL PACKAGE_FIND_VERSION)
    set(PACKAGE_VERSION_EXACT TRUE)
  endif()
else()
  set(PACKAGE_VERSION_COMPATIBLE TRUE)
endif()
