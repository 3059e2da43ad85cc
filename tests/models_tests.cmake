# Tests of the virtual machine tool and the identification models (DBB).
guideway_add_test(machine_test SOURCES machine_test.cpp LIBS guideway_machine)
guideway_add_test(dbb_lai_test SOURCES dbb_lai_test.cpp LIBS guideway_dbb_sim)
guideway_add_test(dbb_diagnostics_test SOURCES dbb_diagnostics_test.cpp LIBS guideway_dbb_sim)
guideway_add_test(dbb_run_test SOURCES dbb_run_test.cpp LIBS guideway_model_dbb)
guideway_add_test(dbb_lsq_test SOURCES dbb_lsq_test.cpp LIBS guideway_model_dbb)
add_test(NAME dbb_cli_test COMMAND /usr/bin/python3 ${CMAKE_CURRENT_SOURCE_DIR}/dbb_cli_test.py ${PROJECT_BINARY_DIR} ${PROJECT_SOURCE_DIR})
set_tests_properties(dbb_cli_test PROPERTIES LABELS integration TIMEOUT 120)
guideway_add_test(compensation_test SOURCES compensation_test.cpp LIBS guideway_model_compensation guideway_dbb_sim guideway_formats)
