# ctest: cmake --install into a fresh prefix, then the module imported from the prefix's
# site-packages (not the build tree) bends the cactus. -D BUILD_DIR, WORK_DIR, PYTHON, SITE (relative).
file(REMOVE_RECURSE "${WORK_DIR}")
execute_process(COMMAND ${CMAKE_COMMAND} --install "${BUILD_DIR}" --prefix "${WORK_DIR}" RESULT_VARIABLE result OUTPUT_QUIET ERROR_VARIABLE output)
if(NOT result EQUAL 0)
  message(FATAL_ERROR "cmake --install failed: ${output}")
endif()
execute_process(COMMAND ${CMAKE_COMMAND} -E env "PYTHONPATH=${WORK_DIR}/${SITE}" ${PYTHON} "${CMAKE_CURRENT_LIST_DIR}/check_installed.py" "${WORK_DIR}"
                RESULT_VARIABLE result OUTPUT_VARIABLE output ERROR_VARIABLE output)
if(NOT result EQUAL 0)
  message(FATAL_ERROR "the installed module failed: ${output}")
endif()
message(STATUS "${output}")
file(REMOVE_RECURSE "${WORK_DIR}")
