# SuiteSparse COLAMD as the imported target lslam::colamd.
# Debian's libsuitesparse-dev ships no CMake config or pkg-config file, so we find the header and the
# two libraries ourselves. Only COLAMD and SuiteSparse_config are linked: nothing else of SuiteSparse.
if(TARGET lslam::colamd)
  return()
endif()
find_path(LSLAM_COLAMD_INCLUDE_DIR colamd.h PATH_SUFFIXES suitesparse REQUIRED)
find_library(LSLAM_COLAMD_LIBRARY colamd REQUIRED)
find_library(LSLAM_SUITESPARSECONFIG_LIBRARY suitesparseconfig REQUIRED)
add_library(lslam::suitesparseconfig UNKNOWN IMPORTED)
set_target_properties(lslam::suitesparseconfig PROPERTIES IMPORTED_LOCATION
                      "${LSLAM_SUITESPARSECONFIG_LIBRARY}")
add_library(lslam::colamd UNKNOWN IMPORTED)
set_target_properties(lslam::colamd PROPERTIES
  IMPORTED_LOCATION "${LSLAM_COLAMD_LIBRARY}"
  INTERFACE_INCLUDE_DIRECTORIES "${LSLAM_COLAMD_INCLUDE_DIR}"
  INTERFACE_LINK_LIBRARIES lslam::suitesparseconfig)
