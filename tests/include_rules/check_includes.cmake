# Checks every #include "dir/file.h" of the libraries against the dependency direction
# of the architecture (docs/architecture.md):
#
#   render     -> solver, visibility, scenes, sampling (the run, render/run.h, wires
#                 the solver's chains to the image; the rest of render reads the field)
#   solver     -> visibility, sampling, scenes
#   visibility -> scenes
#   sampling   -> (nothing of ours)
#   scenes     -> (nothing of ours)
#
# apps/, bench/ and tests/ may include anything. Usage:
#   cmake -DROOT=<source tree> -P check_includes.cmake
# Prints each violation as FILE:LINE: "include", and fails when there is one.
cmake_minimum_required(VERSION 3.20)
if(NOT DEFINED ROOT)
  message(FATAL_ERROR "usage: cmake -DROOT=<source tree> -P check_includes.cmake")
endif()

set(allowed_scenes "scenes")
set(allowed_sampling "sampling")
set(allowed_visibility "visibility;scenes")
set(allowed_solver "solver;visibility;sampling;scenes")
set(allowed_render "render;solver;visibility;scenes;sampling")
set(modules scenes sampling visibility solver render)

set(violations 0)
set(checked 0)
foreach(module IN LISTS modules)
  file(GLOB_RECURSE sources "${ROOT}/${module}/*.h" "${ROOT}/${module}/*.cpp")
  foreach(source IN LISTS sources)
    file(STRINGS "${source}" lines)
    set(line_number 0)
    foreach(line IN LISTS lines)
      math(EXPR line_number "${line_number} + 1")
      if(NOT line MATCHES "^[ \t]*#[ \t]*include[ \t]*\"([^\"]+)\"")
        continue()
      endif()
      set(target "${CMAKE_MATCH_1}")
      math(EXPR checked "${checked} + 1")
      if(NOT target MATCHES "^([a-z_]+)/")
        continue()  # a file beside the source: the same module
      endif()
      set(dir "${CMAKE_MATCH_1}")
      if(NOT dir IN_LIST modules)
        continue()  # not one of ours (a library's own directory layout)
      endif()
      if(dir IN_LIST allowed_${module} OR target IN_LIST allowed_${module})
        continue()
      endif()
      file(RELATIVE_PATH shown "${ROOT}" "${source}")
      message(STATUS "${shown}:${line_number}: ${module}/ may not include \"${target}\"")
      math(EXPR violations "${violations} + 1")
    endforeach()
  endforeach()
endforeach()

if(checked EQUAL 0)
  message(FATAL_ERROR "no includes found under ${ROOT}: wrong ROOT?")
endif()
if(violations GREATER 0)
  message(FATAL_ERROR "${violations} includes against the dependency direction (of ${checked} checked)")
endif()
message(STATUS "${checked} includes follow the dependency direction")
