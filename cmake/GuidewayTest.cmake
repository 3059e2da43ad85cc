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
function(guideway_add_test name)
  cmake_parse_arguments(T "" "TIMEOUT" "SOURCES;LIBS;LABELS;ARGS;GROUPS" ${ARGN})
  add_executable(${name} ${T_SOURCES})
  target_link_libraries(${name} PRIVATE ${T_LIBS} GTest::gtest GTest::gtest_main guideway_warnings)
  target_compile_options(${name} PRIVATE ${GUIDEWAY_THIN_PROGRAM_OPTIONS})
  target_compile_definitions(${name} PRIVATE
    GUIDEWAY_SOURCE_DIR="${PROJECT_SOURCE_DIR}"
    GUIDEWAY_BINARY_DIR="${PROJECT_BINARY_DIR}"
    GUIDEWAY_TEST_DATA_DIR="${PROJECT_SOURCE_DIR}/tests/data")
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
