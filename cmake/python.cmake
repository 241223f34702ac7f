# The Python module (python/), when pybind11 and a Python with its development files are found.
# Not in sanitizer or fuzzing builds: an interpreter cannot load their instrumented objects
# without preloading the sanitizer runtime.
if(HDEFORM_PYTHON STREQUAL "OFF" OR HDEFORM_SANITIZE OR HDEFORM_FUZZ)
  return()
endif()
# The module is a shared object that links the static libraries, so they are position-independent
# whenever a module may be built, found or not: a tree that gains pybind11 later (scripts/run, then
# scripts/test) keeps every object it compiled.
set_target_properties(hdeform_solver hdeform_commands PROPERTIES POSITION_INDEPENDENT_CODE ON)
if(TARGET hdeform_engine)
  set_target_properties(hdeform_engine PROPERTIES POSITION_INDEPENDENT_CODE ON)
endif()
# Debian's interpreter is the one its pybind11 and numpy packages serve; an interpreter earlier on
# PATH (pyenv, a virtual environment) has neither. Python_EXECUTABLE overrides.
if(NOT DEFINED Python_EXECUTABLE AND EXISTS /usr/bin/python3)
  set(Python_EXECUTABLE /usr/bin/python3)
endif()
find_package(Python 3.8 COMPONENTS Interpreter Development.Module)
if(Python_FOUND)
  set(PYBIND11_FINDPYTHON ON)
  find_package(pybind11 2.6 CONFIG)
endif()
if(NOT Python_FOUND OR NOT pybind11_FOUND)
  if(HDEFORM_PYTHON STREQUAL "ON")
    message(FATAL_ERROR "HDEFORM_PYTHON=ON needs Python's development files and pybind11 (python3-dev pybind11-dev)")
  endif()
  message(STATUS "hdeform: no Python module (Python development files or pybind11 not found)")
  return()
endif()
add_subdirectory(python)
# The Blender add-on uses the module.
add_subdirectory(blender)
