# Included by each interface package here after rosidl_generate_interfaces().
# The PyPI wheels of the Jazzy message packages export their *__rosidl_generator_py targets with
# the include directories of the machine that built the wheels (/opt/python/cp311-cp311/...,
# a manylinux image). CMake refuses to generate with a non-existent include directory, so drop
# every such entry from the imported targets; our own Python extension gets this machine's
# Python and NumPy include directories from rosidl_generator_py's find_package(Python3 ...).
get_property(_imported_targets DIRECTORY PROPERTY IMPORTED_TARGETS)
foreach(_target IN LISTS _imported_targets)
  get_target_property(_dirs ${_target} INTERFACE_INCLUDE_DIRECTORIES)
  if(NOT _dirs)
    continue()
  endif()
  set(_kept "")
  foreach(_dir IN LISTS _dirs)
    if(_dir MATCHES "^/" AND NOT _dir MATCHES "\\$<" AND NOT EXISTS "${_dir}")
      message(STATUS "${PROJECT_NAME}: dropping ${_target}'s missing include directory ${_dir}")
    else()
      list(APPEND _kept "${_dir}")
    endif()
  endforeach()
  set_target_properties(${_target} PROPERTIES INTERFACE_INCLUDE_DIRECTORIES "${_kept}")
endforeach()
