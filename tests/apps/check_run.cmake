# Runs COMMAND (a ;-list) and checks its exit code (EXPECT_EXIT) and that stdout+stderr match
# EXPECT_MATCH. Used by sph_check_run() in CMakeLists.txt.
execute_process(COMMAND ${COMMAND} RESULT_VARIABLE rc OUTPUT_VARIABLE out ERROR_VARIABLE err)
set(all "${out}${err}")
if(NOT rc STREQUAL "${EXPECT_EXIT}")
  message(FATAL_ERROR "exit code ${rc}, expected ${EXPECT_EXIT}\n${all}")
endif()
if(EXPECT_MATCH AND NOT all MATCHES "${EXPECT_MATCH}")
  message(FATAL_ERROR "output does not match '${EXPECT_MATCH}':\n${all}")
endif()
message(STATUS "exit ${rc} as expected")
