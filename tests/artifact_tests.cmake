# 1-D artifact (Wei 2019): recovery of the virtual machine tool's six error motions, coverage, bad
# input; the CLI end to end against an independent numpy evaluation of Wei's equations.
guideway_add_test(artifact_test SOURCES artifact_test.cpp
  LIBS guideway_artifact_model guideway_measurement_files guideway_machine LABELS unit TIMEOUT 60)
add_test(NAME artifact_cli_test
  COMMAND /usr/bin/python3 ${CMAKE_CURRENT_SOURCE_DIR}/artifact_cli_test.py $<TARGET_FILE:guideway>
          $<TARGET_FILE:guideway-emulate> ${CMAKE_CURRENT_SOURCE_DIR}/artifact_wei2019_machine.toml)
set_tests_properties(artifact_cli_test PROPERTIES LABELS integration TIMEOUT 120)
