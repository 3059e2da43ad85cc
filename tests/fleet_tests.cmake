# Tests of fleet/: the store on real SQLite files, the headline figures of the golden results, the moved
# flag and the fleet status (gtest); the `guideway fleet` commands end to end, the report in headless
# Chromium (fleet_cli_test.py; Chromium missing is a failure: ./scripts/setup.sh installs it).
guideway_add_test(fleet_store_test SOURCES fleet_store_test.cpp LIBS guideway_fleet PkgConfig::SQLITE3 LABELS unit)
add_test(NAME fleet_cli_test
  COMMAND /usr/bin/python3 ${CMAKE_CURRENT_SOURCE_DIR}/fleet_cli_test.py $<TARGET_FILE:guideway> ${PROJECT_SOURCE_DIR}
          ${PROJECT_BINARY_DIR}/fleet_artifacts)
set_tests_properties(fleet_cli_test PROPERTIES LABELS integration TIMEOUT 180)
# Nothing acknowledged is lost: fleet serve killed at random points of a flood, on a full disk, behind a
# locked database (Debian's mosquitto and mosquitto_pub; skipped with the reason when they are missing).
add_test(NAME fleet_delivery_test
  COMMAND /usr/bin/python3 ${CMAKE_CURRENT_SOURCE_DIR}/fleet_delivery_test.py ${PROJECT_BINARY_DIR})
set_tests_properties(fleet_delivery_test PROPERTIES LABELS integration TIMEOUT 300 SKIP_RETURN_CODE 77)
# fleet serve against a broker that accepts and says nothing, or no SUBACK (issue 46 items 8 and 13).
add_test(NAME fleet_serve_silent_broker_test
  COMMAND /usr/bin/python3 ${CMAKE_CURRENT_SOURCE_DIR}/fleet_serve_silent_broker_test.py ${PROJECT_BINARY_DIR})
set_tests_properties(fleet_serve_silent_broker_test PROPERTIES LABELS integration TIMEOUT 120)
