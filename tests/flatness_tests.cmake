# Tests of models/flatness: straightness from angles, Union Jack (Moody 1955 data), run-out squareness.
guideway_add_test(flatness_straightness_test SOURCES flatness_straightness_test.cpp
  LIBS guideway_flatness_models guideway_machine LABELS unit)
guideway_add_test(flatness_union_jack_test SOURCES flatness_union_jack_test.cpp LIBS guideway_flatness_models LABELS unit)
guideway_add_test(flatness_runout_test SOURCES flatness_runout_test.cpp
  LIBS guideway_flatness_models guideway_machine LABELS unit)
guideway_add_test(dabam_reader_property_test SOURCES dabam_reader_property_test.cpp LIBS guideway_formats
  LABELS unit)
# The CLI end to end, numpy's lstsq as the oracle of --least-squares, and the single-precision origin
# of the Moody reference (numpy exists only under /usr/bin/python3).
add_test(NAME flatness_cli_test
  COMMAND /usr/bin/python3 ${CMAKE_CURRENT_SOURCE_DIR}/flatness_cli_test.py $<TARGET_FILE:guideway>
          ${PROJECT_SOURCE_DIR}/tests/data/moody1955)
set_tests_properties(flatness_cli_test PROPERTIES LABELS integration TIMEOUT 120)
# Every real DABAM slope profile (tests/data/dabam) through `identify straightness`: numpy's integration,
# PyWavelets' scatter, the named instruments' ranges (numpy and pywt exist only under /usr/bin/python3).
add_test(NAME dabam_straightness_test
  COMMAND /usr/bin/python3 ${CMAKE_CURRENT_SOURCE_DIR}/dabam_straightness_test.py $<TARGET_FILE:guideway>
          ${PROJECT_SOURCE_DIR}/tests/data/dabam)
set_tests_properties(dabam_straightness_test PROPERTIES LABELS integration TIMEOUT 120)
