# The built-in driver table and plugin loading, with an example plugin built into a test directory.
set(GUIDEWAY_TEST_PLUGIN_DIR ${CMAKE_CURRENT_BINARY_DIR}/test_plugins)
add_library(example_driver_plugin MODULE ${CMAKE_CURRENT_LIST_DIR}/example_driver_plugin.cpp)
target_link_libraries(example_driver_plugin PRIVATE guideway_drivers guideway_warnings)
set_target_properties(example_driver_plugin PROPERTIES PREFIX "" LIBRARY_OUTPUT_DIRECTORY ${GUIDEWAY_TEST_PLUGIN_DIR}
                                                       POSITION_INDEPENDENT_CODE ON)
guideway_add_test(driver_plugin_test SOURCES ${CMAKE_CURRENT_LIST_DIR}/driver_plugin_test.cpp
  LIBS guideway_builtin_drivers LABELS unit)
target_compile_definitions(driver_plugin_test PRIVATE GUIDEWAY_TEST_PLUGIN_DIR="${GUIDEWAY_TEST_PLUGIN_DIR}")
add_dependencies(driver_plugin_test example_driver_plugin)
