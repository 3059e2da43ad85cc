# CAN (dbb-can) and serial (autocollimator-serial) drivers, their transports, parsers and emulators.
guideway_add_test(dbb_driver_test SOURCES dbb_driver_test.cpp LIBS guideway_dbb guideway_emu_can_serial_sources
                  ARGS --gtest_filter=-*5kHz*:DbbDriverAlone.* LABELS integration tsan TIMEOUT 180)
# The 5 kHz cases need the emulator to answer each SYNC within its 200 us period, and DbbDriverAlone.*
# measure wake-ups at 10 kHz: run alone, not beside another test competing for the machine's two cores
# (a clean-clone main stage once failed that way).
add_test(NAME dbb_driver_5khz_test COMMAND dbb_driver_test --gtest_filter=*5kHz*:DbbDriverAlone.*)
set_tests_properties(dbb_driver_5khz_test PROPERTIES LABELS integration RUN_SERIAL TRUE TIMEOUT 120)
guideway_add_test(autocollimator_driver_test SOURCES autocollimator_driver_test.cpp
                  LIBS guideway_autocollimator guideway_emu_can_serial_sources LABELS integration tsan TIMEOUT 180)
guideway_add_test(dbb_driver_protocol_fuzz_test SOURCES dbb_driver_protocol_fuzz_test.cpp LIBS guideway_dbb)
guideway_add_test(autocollimator_protocol_fuzz_test SOURCES autocollimator_protocol_fuzz_test.cpp
                  LIBS guideway_autocollimator)
guideway_add_test(can_io_test SOURCES can_io_test.cpp LIBS guideway_can)
guideway_add_test(serial_port_test SOURCES serial_port_test.cpp LIBS guideway_serial)
# The emulators and guidewayd as processes; the drivers are built into guidewayd.
add_test(NAME can_serial_process_test
  COMMAND /usr/bin/python3 ${CMAKE_CURRENT_SOURCE_DIR}/can_serial_process_test.py ${PROJECT_BINARY_DIR}
          ${PROJECT_SOURCE_DIR})
set_tests_properties(can_serial_process_test PROPERTIES LABELS integration TIMEOUT 120)
# CANopen services and the dbb-can network management (NMT, heartbeat, EMCY, SDO checks), pure and fuzzed.
guideway_add_test(canopen_network_test SOURCES canopen_network_test.cpp LIBS guideway_dbb)
# dbb-can with CANopen nodes that boot, stop and reboot: one test per node fault (emulated nodes).
guideway_add_test(dbb_nodes_test SOURCES dbb_nodes_test.cpp LIBS guideway_dbb guideway_emu_can_serial_sources
                  LABELS integration tsan TIMEOUT 120)
# guidewayd with three CANopen nodes written independently of Guideway from the CiA 301 facts (Python).
add_test(NAME canopen_daemon_test
  COMMAND /usr/bin/python3 ${CMAKE_CURRENT_SOURCE_DIR}/canopen_daemon_test.py ${PROJECT_BINARY_DIR})
set_tests_properties(canopen_daemon_test PROPERTIES LABELS integration TIMEOUT 60)
