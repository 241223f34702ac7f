# ctest: cmake --install into a fresh prefix; Blender enables the add-on from the prefix's
# site-packages (not the source tree) and bends the cactus; the installed zip holds the package.
# -D BUILD_DIR, WORK_DIR, BLENDER, SITE and DATA (relative to the prefix), SCRIPT.
file(REMOVE_RECURSE "${WORK_DIR}")
execute_process(COMMAND ${CMAKE_COMMAND} --install "${BUILD_DIR}" --prefix "${WORK_DIR}" RESULT_VARIABLE result OUTPUT_QUIET ERROR_VARIABLE output)
if(NOT result EQUAL 0)
  message(FATAL_ERROR "cmake --install failed: ${output}")
endif()
file(ARCHIVE_EXTRACT INPUT "${WORK_DIR}/${DATA}/hdeform/hdeform_blender.zip" DESTINATION "${WORK_DIR}/unzipped")
if(NOT EXISTS "${WORK_DIR}/unzipped/hdeform_blender/__init__.py")
  message(FATAL_ERROR "the zip does not hold hdeform_blender/__init__.py")
endif()
execute_process(COMMAND ${CMAKE_COMMAND} -E env "PYTHONPATH=${WORK_DIR}/${SITE}" "HDEFORM_INSTALLED=${WORK_DIR}/${SITE}"
                        ${BLENDER} -b --factory-startup --python-exit-code 1 --python "${SCRIPT}"
                RESULT_VARIABLE result OUTPUT_VARIABLE output ERROR_VARIABLE output)
if(NOT result EQUAL 0 OR NOT output MATCHES "PASSED")
  message(FATAL_ERROR "the installed add-on failed: ${output}")
endif()
message(STATUS "${output}")
file(REMOVE_RECURSE "${WORK_DIR}")
