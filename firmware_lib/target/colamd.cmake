# lslam::colamd for bare-metal targets: COLAMD compiled from the source of Debian's suitesparse
# package (fetched into the build tree once per build folder, never committed) with the target's
# flags, and the project's own SuiteSparse_config object (no malloc, no printf).
set(LSLAM_SUITESPARSE_SOURCE_DIR ${CMAKE_BINARY_DIR}/_deps/suitesparse)
if(NOT EXISTS ${LSLAM_SUITESPARSE_SOURCE_DIR}/COLAMD/Source/colamd.c)
  message(STATUS "lslam: fetching COLAMD from Debian's suitesparse source package")
  execute_process(COMMAND ${CMAKE_CURRENT_LIST_DIR}/fetch-suitesparse ${LSLAM_SUITESPARSE_SOURCE_DIR}
                  RESULT_VARIABLE fetch_result)
  if(NOT fetch_result EQUAL 0)
    message(FATAL_ERROR "lslam: could not fetch the suitesparse source package (apt-get source)")
  endif()
endif()
add_library(lslam_colamd STATIC ${LSLAM_SUITESPARSE_SOURCE_DIR}/COLAMD/Source/colamd.c
            ${CMAKE_CURRENT_LIST_DIR}/suitesparse_config.c)
add_library(lslam::colamd ALIAS lslam_colamd)
set_target_properties(lslam_colamd PROPERTIES C_STANDARD 99 C_STANDARD_REQUIRED ON)
target_include_directories(lslam_colamd SYSTEM PUBLIC ${LSLAM_SUITESPARSE_SOURCE_DIR}/COLAMD/Include
                           ${LSLAM_SUITESPARSE_SOURCE_DIR}/SuiteSparse_config)
# Third-party code: built with its own (clean) defaults, not the project's warnings; NDEBUG turns
# its debug checks (and their printf) off.
target_compile_definitions(lslam_colamd PRIVATE NDEBUG)
