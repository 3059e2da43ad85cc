# Instrument identity and calibration: the [[device]] keys and checks, the recording and PARAMS headers,
# the report's table, the fleet's history, dbb-can's bar serial and calibrated length.
guideway_add_test(instrument_test SOURCES instrument_test.cpp
                  LIBS guideway_daemon guideway_formats guideway_results guideway_report guideway_fleet guideway_dbb)
# The bar's calibrated length in the DBB uncertainties, against numpy (offline identification and replay).
add_test(NAME bar_length_uncertainty_test
  COMMAND /usr/bin/python3 ${CMAKE_CURRENT_SOURCE_DIR}/bar_length_uncertainty_test.py ${PROJECT_BINARY_DIR}
          ${PROJECT_SOURCE_DIR})
set_tests_properties(bar_length_uncertainty_test PROPERTIES LABELS integration TIMEOUT 120)
