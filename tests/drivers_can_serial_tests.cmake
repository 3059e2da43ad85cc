# CAN (dbb-can) and serial (autocollimator-serial) drivers, their transports, parsers and emulators.
guideway_add_test(dbb_driver_test SOURCES dbb_driver_test.cpp LIBS guideway_dbb guideway_emu_can_serial_sources
                  LABELS integration tsan TIMEOUT 180)
guideway_add_test(autocollimator_driver_test SOURCES autocollimator_driver_test.cpp
                  LIBS guideway_autocollimator guideway_emu_can_serial_sources LABELS integration tsan TIMEOUT 180)
guideway_add_test(dbb_driver_protocol_fuzz_test SOURCES dbb_driver_protocol_fuzz_test.cpp LIBS guideway_dbb)
guideway_add_test(autocollimator_protocol_fuzz_test SOURCES autocollimator_protocol_fuzz_test.cpp
                  LIBS guideway_autocollimator)
guideway_add_test(can_io_test SOURCES can_io_test.cpp LIBS guideway_can)
guideway_add_test(serial_port_test SOURCES serial_port_test.cpp LIBS guideway_serial)
