# Workpiece flatness (Mu 2012 Secs. 3-4): the emulated experiment, uncertainty coverage, bad input;
# the CLI end to end against numpy/PyWavelets (only under /usr/bin/python3).
guideway_add_test(workpiece_flatness_test SOURCES workpiece_flatness_test.cpp
  LIBS guideway_flatness_models guideway_measurement_files guideway_machine LABELS unit TIMEOUT 120)
add_test(NAME workpiece_flatness_cli_test
  COMMAND /usr/bin/python3 ${CMAKE_CURRENT_SOURCE_DIR}/workpiece_flatness_cli_test.py $<TARGET_FILE:guideway>
          $<TARGET_FILE:guideway-emulate> ${CMAKE_CURRENT_SOURCE_DIR}/workpiece_flatness_mu2012_machine.toml)
set_tests_properties(workpiece_flatness_cli_test PROPERTIES LABELS integration TIMEOUT 120)
