# guideway_add_test(NAME SOURCES src... [LIBS lib...] [LABELS label...] [TIMEOUT s] [ARGS arg...]
#                   [GROUPS group=filter...])
# One GoogleTest executable registered as one ctest test with labels (unit, integration, slow, tsan...).
# GROUPS registers it as ctest tests NAME-group instead, each running the cases its GoogleTest filter
# names, and NAME-rest running every other case: a heavy executable then keeps its margin to the timeout
# under a sanitizer and spreads over the cores instead of ending the run alone. Groups by measured cost
# (GoogleTest's own sharding deals cases round-robin, so two heavy ones may share a shard).
find_package(GTest REQUIRED)
# The tests labelled tsan, so the TSan build compiles only what it runs.
add_custom_target(guideway_tsan_tests)

# What every test program compiles with: the test executables and their precompiled header's owner alike,
# since a reused precompiled header needs the same compile options. In the optimized builds a test program
# is compiled at -O1: it drives code the libraries hold, and they are built as shipped (-O3 in Release);
# code generation at -O3 was most of a test file's compile (8 test files, each compiled at -O3 and at -O1
# in turn, twice: 213 against 152 s of CPU, -29 %). AS_BUILT keeps the build's own level, for the tests
# whose subject is header code compiled into the test itself (the rings: the tests labelled tsan).
# Clang's precompiled header takes either (both are "optimized" to it).
function(guideway_test_compile_settings target)
  cmake_parse_arguments(S "AS_BUILT" "" "" ${ARGN})
  target_link_libraries(${target} PRIVATE GTest::gtest GTest::gtest_main nlohmann_json::nlohmann_json guideway_warnings
    guideway_test_support)
  if(NOT S_AS_BUILT)
    target_compile_options(${target} PRIVATE "$<$<CONFIG:Release,RelWithDebInfo,MinSizeRel>:-O1>")
  endif()
  # Clang stamps a precompiled header with its headers' mtimes unless told not to: ccache then declines it.
  target_compile_options(${target} PRIVATE ${GUIDEWAY_THIN_CODE_OPTIONS}
    "$<$<CXX_COMPILER_ID:Clang>:SHELL:-Xclang -fno-pch-timestamp>")
  target_compile_definitions(${target} PRIVATE
    GUIDEWAY_SOURCE_DIR="${PROJECT_SOURCE_DIR}"
    GUIDEWAY_BINARY_DIR="${PROJECT_BINARY_DIR}"
    GUIDEWAY_TEST_DATA_DIR="${PROJECT_SOURCE_DIR}/tests/data")
endfunction()

# GoogleTest, nlohmann::json and the standard headers the tests share, parsed once for all of them, with
# Clang (the sanitizer stages): there a test file at -O0 is mostly that parsing, and the precompiled
# header cut the CPU of 16 test files (the heaviest and typical ones, each compiled with and without it in
# turn) by 27 % under ASan (131 s against 178 s). Not with GCC: in the Release build the same files took
# 3 % less (230 s against 237 s, within the noise; code generation at -O3 is most of their time) for a
# 130 MB header and its own compile. Its owner is an executable (a test program with no tests), so that it
# compiles with the tests' flags (-fPIE, not a library's -fPIC); a test compiled with other options opts
# out with the target property DISABLE_PRECOMPILE_HEADERS. Made by the first test, in its folder of tests/:
# it then has the options every folder of tests/ inherits too (guideway_sanitize_as_test_programs).
function(guideway_add_test_pch)
  file(CONFIGURE OUTPUT ${CMAKE_CURRENT_BINARY_DIR}/guideway_test_pch.cpp
    CONTENT "// The owner of the test programs' shared precompiled header (cmake/GuidewayTest.cmake).\n")
  add_executable(guideway_test_pch ${CMAKE_CURRENT_BINARY_DIR}/guideway_test_pch.cpp)
  guideway_test_compile_settings(guideway_test_pch)
  target_precompile_headers(guideway_test_pch PRIVATE
    <gtest/gtest.h> <nlohmann/json.hpp>
    <algorithm> <atomic> <chrono> <cmath> <filesystem> <fstream> <functional> <map> <numbers> <random>
    <sstream> <string> <thread> <vector>)
endfunction()

function(guideway_add_test name)
  cmake_parse_arguments(T "" "TIMEOUT" "SOURCES;LIBS;LABELS;ARGS;GROUPS" ${ARGN})
  add_executable(${name} ${T_SOURCES})
  target_link_libraries(${name} PRIVATE ${T_LIBS})
  if("tsan" IN_LIST T_LABELS)
    guideway_test_compile_settings(${name} AS_BUILT)
  else()
    guideway_test_compile_settings(${name})
  endif()
  if(CMAKE_CXX_COMPILER_ID STREQUAL "Clang")
    if(NOT TARGET guideway_test_pch)
      guideway_add_test_pch()
    endif()
    target_precompile_headers(${name} REUSE_FROM guideway_test_pch)
  endif()
  if(NOT T_LABELS)
    set(T_LABELS unit)
  endif()
  if(NOT T_TIMEOUT)
    set(T_TIMEOUT 120)
  endif()
  if(T_GROUPS)
    set(named "")
    foreach(group ${T_GROUPS})
      string(REGEX MATCH "^([A-Za-z0-9_]+)=(.+)$" matched "${group}")
      if(NOT matched)
        message(FATAL_ERROR "guideway_add_test(${name}): GROUPS item '${group}' is not name=filter")
      endif()
      set(test_name ${name}-${CMAKE_MATCH_1})
      add_test(NAME ${test_name} COMMAND ${name} ${T_ARGS} --gtest_filter=${CMAKE_MATCH_2})
      set_tests_properties(${test_name} PROPERTIES LABELS "${T_LABELS}" TIMEOUT ${T_TIMEOUT})
      string(APPEND named ":${CMAKE_MATCH_2}")
    endforeach()
    string(SUBSTRING "${named}" 1 -1 named)
    add_test(NAME ${name}-rest COMMAND ${name} ${T_ARGS} --gtest_filter=-${named})
    set_tests_properties(${name}-rest PROPERTIES LABELS "${T_LABELS}" TIMEOUT ${T_TIMEOUT})
  else()
    add_test(NAME ${name} COMMAND ${name} ${T_ARGS})
    set_tests_properties(${name} PROPERTIES LABELS "${T_LABELS}" TIMEOUT ${T_TIMEOUT})
  endif()
  if("tsan" IN_LIST T_LABELS)
    add_dependencies(guideway_tsan_tests ${name})
  endif()
endfunction()
