# Every reader of docs/formats.md against random and broken files, and the bounds of core/input_file.hpp
# (issue 46 item 3): in-process (the readers) and through the CLI (special files, the size and row
# bounds, memory and time a run).
guideway_add_test(input_readers_property_test SOURCES input_readers_property_test.cpp
  LIBS guideway_formats guideway_flatness_models guideway_artifact_model guideway_explain_model LABELS unit)
add_test(NAME input_files_cli_test
  COMMAND /usr/bin/python3 ${CMAKE_CURRENT_SOURCE_DIR}/input_files_cli_test.py ${PROJECT_BINARY_DIR})
set_tests_properties(input_files_cli_test PROPERTIES LABELS integration TIMEOUT 300)
