# guideway_add_test(NAME SOURCES src... [LIBS lib...] [LABELS label...] [TIMEOUT s] [ARGS arg...])
# One GoogleTest executable registered as one ctest test with labels (unit, integration, slow, tsan...).
find_package(GTest REQUIRED)
# The tests labelled tsan, so the TSan build compiles only what it runs.
add_custom_target(guideway_tsan_tests)
function(guideway_add_test name)
  cmake_parse_arguments(T "" "TIMEOUT" "SOURCES;LIBS;LABELS;ARGS" ${ARGN})
  add_executable(${name} ${T_SOURCES})
  target_link_libraries(${name} PRIVATE ${T_LIBS} GTest::gtest GTest::gtest_main guideway_warnings)
  target_compile_options(${name} PRIVATE ${GUIDEWAY_THIN_PROGRAM_OPTIONS})
  target_compile_definitions(${name} PRIVATE
    GUIDEWAY_SOURCE_DIR="${PROJECT_SOURCE_DIR}"
    GUIDEWAY_BINARY_DIR="${PROJECT_BINARY_DIR}"
    GUIDEWAY_TEST_DATA_DIR="${PROJECT_SOURCE_DIR}/tests/data")
  add_test(NAME ${name} COMMAND ${name} ${T_ARGS})
  if(NOT T_LABELS)
    set(T_LABELS unit)
  endif()
  if(NOT T_TIMEOUT)
    set(T_TIMEOUT 120)
  endif()
  set_tests_properties(${name} PROPERTIES LABELS "${T_LABELS}" TIMEOUT ${T_TIMEOUT})
  if("tsan" IN_LIST T_LABELS)
    add_dependencies(guideway_tsan_tests ${name})
  endif()
endfunction()
