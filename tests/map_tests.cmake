# The error map (models/map, docs/map.md): the chain against the virtual machine's, its derivatives and gauge, the
# ISO 230-1 tables, the artifact and the traverse on any axis, the day's manifest, a partial day; the 21 errors of
# two machines recovered from a simulated day, the volumetric accuracy, the tables verified on the virtual
# machine, the uncertainties over 30 days (Release only); the fit against numpy; the CLI and the report in
# Chromium; the map file, the day manifest and the ISO tables broken at random: read or refused with their own error.
guideway_add_test(map_test SOURCES map_test.cpp
  LIBS guideway_map_model guideway_map_truth guideway_measurement_files guideway_artifact_model guideway_formats
  LABELS unit TIMEOUT 120)
guideway_add_test(map_recovery_test SOURCES map_recovery_test.cpp
  LIBS guideway_map_model guideway_map_truth guideway_measurement_files LABELS unit TIMEOUT 300)
guideway_add_test(map_files_property_test SOURCES map_files_property_test.cpp
  LIBS guideway_map_model guideway_map_truth guideway_measurement_files guideway_formats LABELS unit TIMEOUT 120)
add_test(NAME map_numpy_test
  COMMAND /usr/bin/python3 ${CMAKE_CURRENT_SOURCE_DIR}/map_numpy_test.py $<TARGET_FILE:guideway>
          ${PROJECT_SOURCE_DIR}/config/machine-example.toml ${PROJECT_BINARY_DIR}/map_numpy_work)
set_tests_properties(map_numpy_test PROPERTIES LABELS integration TIMEOUT 120)
add_test(NAME map_sequence_test
  COMMAND /usr/bin/python3 ${CMAKE_CURRENT_SOURCE_DIR}/map_sequence_test.py $<TARGET_FILE:guidewayd>
          $<TARGET_FILE:guideway> ${PROJECT_BINARY_DIR}/map_sequence_work)
set_tests_properties(map_sequence_test PROPERTIES LABELS integration TIMEOUT 300)
