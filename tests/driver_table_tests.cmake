# The built-in driver table and plugin loading: the example C plugin and a faulty one in a test plugin
# directory, and two broken builds of the example (another ABI version, no entry point) in their own.
set(GUIDEWAY_TEST_PLUGIN_DIR ${CMAKE_CURRENT_BINARY_DIR}/test_plugins)
set(GUIDEWAY_BROKEN_PLUGIN_DIR ${CMAKE_CURRENT_BINARY_DIR}/broken_plugins)
guideway_add_test(driver_plugin_test SOURCES ${CMAKE_CURRENT_LIST_DIR}/driver_plugin_test.cpp
  LIBS guideway_builtin_drivers LABELS unit tsan)
target_compile_definitions(driver_plugin_test PRIVATE GUIDEWAY_TEST_PLUGIN_DIR="${GUIDEWAY_TEST_PLUGIN_DIR}"
  GUIDEWAY_BROKEN_PLUGIN_DIR="${GUIDEWAY_BROKEN_PLUGIN_DIR}")

# The example plugin (drivers/CMakeLists.txt, guideway_add_driver_plugin) and its two broken builds.
set(example_plugin_source ${CMAKE_CURRENT_SOURCE_DIR}/example_driver_plugin.c)
guideway_add_driver_plugin(example_driver_plugin SOURCES ${example_plugin_source} TEST_DIR ${GUIDEWAY_TEST_PLUGIN_DIR})
guideway_add_driver_plugin(example_driver_plugin_other_abi SOURCES ${example_plugin_source}
  TEST_DIR ${GUIDEWAY_BROKEN_PLUGIN_DIR}
  DEFINITIONS EXAMPLE_PLUGIN_ABI_VERSION=99)
guideway_add_driver_plugin(example_driver_plugin_no_entry SOURCES ${example_plugin_source}
  TEST_DIR ${GUIDEWAY_BROKEN_PLUGIN_DIR}
  DEFINITIONS EXAMPLE_PLUGIN_ENTRY=example_plugin_misnamed)
guideway_add_driver_plugin(faulty_driver_plugin SOURCES ${CMAKE_CURRENT_SOURCE_DIR}/faulty_driver_plugin.c
  TEST_DIR ${GUIDEWAY_TEST_PLUGIN_DIR})
add_dependencies(driver_plugin_test
  example_driver_plugin example_driver_plugin_other_abi example_driver_plugin_no_entry faulty_driver_plugin)
add_test(NAME driver_plugin_daemon_test
  COMMAND /usr/bin/python3 ${CMAKE_CURRENT_SOURCE_DIR}/driver_plugin_daemon_test.py
  ${PROJECT_BINARY_DIR} ${GUIDEWAY_TEST_PLUGIN_DIR} ${GUIDEWAY_BROKEN_PLUGIN_DIR})
set_tests_properties(driver_plugin_daemon_test PROPERTIES LABELS integration TIMEOUT 120)
