# Every Catch2 test name can be run by CTest: catch_discover_tests cuts a name at ';'
# (CMake's list separator) into two tests that each match nothing, and Catch2 exits 0
# when nothing matches: such a test case would pass without running.
# Usage: cmake -DROOT=<tests folder> -P check_test_names.cmake
get_filename_component(ROOT "${ROOT}" ABSOLUTE)
file(GLOB_RECURSE sources "${ROOT}/*.cpp")
set(bad "")
foreach(source IN LISTS sources)
  file(STRINGS "${source}" lines ENCODING UTF-8 REGEX "TEST_CASE\\(\"[^\"]*")
  foreach(line IN LISTS lines)
    # (file(STRINGS) keeps a line's ';' escaped within its element.)
    if(line MATCHES "TEST_CASE\\(\"[^\"]*;")
      file(RELATIVE_PATH rel "${ROOT}" "${source}")
      string(APPEND bad "\n  ${rel}: ${line}")
    endif()
  endforeach()
endforeach()
if(bad)
  message(FATAL_ERROR "test names with ';' (CTest would not run them):${bad}")
endif()
