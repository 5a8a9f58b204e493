# cmake -DBUILD_DIR=... -DPROGRAM=... -P expect_link_failure.cmake
# Passes only when building PROGRAM fails at the link because of the heap guard: a compile error
# or any other failure does not count as a pass.
execute_process(COMMAND ${CMAKE_COMMAND} --build ${BUILD_DIR} --target ${PROGRAM}
                RESULT_VARIABLE result OUTPUT_VARIABLE output ERROR_VARIABLE output)
if(result EQUAL 0)
  message(FATAL_ERROR "${PROGRAM} linked although it allocates: the link guard does not work")
endif()
if(NOT output MATCHES "undefined reference to `__wrap_(malloc|_malloc_r)'")
  message(FATAL_ERROR "${PROGRAM} failed to build, but not because of the link guard:\n${output}")
endif()
message(STATUS "${PROGRAM}: link rejected by the heap guard, as it must be")
