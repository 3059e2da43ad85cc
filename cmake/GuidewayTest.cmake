# guideway_add_test(NAME SOURCES src... [LIBS lib...] [LABELS label...] [TIMEOUT s] [ARGS arg...] [SHARDS n])
# One GoogleTest executable registered as one ctest test with labels (unit, integration, slow, tsan...).
# SHARDS n registers it as n ctest tests NAME-1ofn ... NAME-nofn instead, each running every n-th case
# (GoogleTest's sharding): a heavy executable then keeps its margin to the timeout under a sanitizer and
# spreads over the cores instead of ending the run alone.
find_package(GTest REQUIRED)
# The tests labelled tsan, so the TSan build compiles only what it runs.
add_custom_target(guideway_tsan_tests)
function(guideway_add_test name)
  cmake_parse_arguments(T "" "TIMEOUT;SHARDS" "SOURCES;LIBS;LABELS;ARGS" ${ARGN})
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
  if(T_SHARDS)
    math(EXPR last "${T_SHARDS} - 1")
    foreach(index RANGE ${last})
      math(EXPR number "${index} + 1")
      set(test_name ${name}-${number}of${T_SHARDS})
      add_test(NAME ${test_name} COMMAND ${name} ${T_ARGS})
      set_tests_properties(${test_name} PROPERTIES LABELS "${T_LABELS}" TIMEOUT ${T_TIMEOUT}
        ENVIRONMENT "GTEST_TOTAL_SHARDS=${T_SHARDS};GTEST_SHARD_INDEX=${index}")
    endforeach()
  else()
    add_test(NAME ${name} COMMAND ${name} ${T_ARGS})
    set_tests_properties(${name} PROPERTIES LABELS "${T_LABELS}" TIMEOUT ${T_TIMEOUT})
  endif()
  if("tsan" IN_LIST T_LABELS)
    add_dependencies(guideway_tsan_tests ${name})
  endif()
endfunction()
