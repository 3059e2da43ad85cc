# Micrometer (Modbus TCP/RTU) and profilometer (TCP stream, profile files): parsers, drivers, emulators.
guideway_add_test(modbus_register_map_test SOURCES modbus_register_map_test.cpp LIBS guideway_modbus)
guideway_add_test(modbus_sample_ring_test SOURCES modbus_sample_ring_test.cpp LIBS guideway_modbus)
# In the TSan stage too: over RTU the driver hands each read to the line's own thread (drivers/modbus/rtu_line).
guideway_add_test(micrometer_modbus_test SOURCES micrometer_modbus_test.cpp
  LIBS guideway_micrometer guideway_micrometer_emulator ARGS --gtest_filter=-MicrometerBufferedAlone.*
  LABELS integration tsan TIMEOUT 180)
# How evenly and how promptly buffered samples are stamped depends on how quickly answers come back
# (through a pty for RTU, delayed by up to a second on a loaded machine): run alone.
add_test(NAME micrometer_modbus_timing_test COMMAND micrometer_modbus_test --gtest_filter=MicrometerBufferedAlone.*)
set_tests_properties(micrometer_modbus_timing_test PROPERTIES LABELS integration RUN_SERIAL TRUE TIMEOUT 120)
guideway_add_test(profilometer_stream_test SOURCES profilometer_stream_test.cpp LIBS guideway_profilometer)
guideway_add_test(profilometer_tcp_test SOURCES profilometer_tcp_test.cpp
  LIBS guideway_profilometer guideway_profilometer_emulator LABELS integration TIMEOUT 180)
guideway_add_test(x3p_profile_files_test SOURCES x3p_profile_files_test.cpp LIBS guideway_formats)
# The daemon as a process with both drivers (built in), reading three emulator processes (RTU pty, TCP, stream).
add_test(NAME micrometer_profilometer_daemon_test
  COMMAND /usr/bin/python3 ${CMAKE_CURRENT_SOURCE_DIR}/micrometer_profilometer_daemon_test.py ${PROJECT_BINARY_DIR})
set_tests_properties(micrometer_profilometer_daemon_test PROPERTIES LABELS integration TIMEOUT 120)
# The micrometer driver against Debian's python3-pymodbus (tests/pymodbus_amplifier.py), a Modbus stack
# written elsewhere: TCP and RTU over a pseudo-terminal pair; skipped with the reason where it is missing.
guideway_add_test(micrometer_foreign_stack_test SOURCES micrometer_foreign_stack_test.cpp LIBS guideway_micrometer
  LABELS integration TIMEOUT 120)
# Debian's mbpoll (a Modbus master written elsewhere) against the emulator, TCP and RTU.
add_test(NAME modbus_mbpoll_test
  COMMAND /usr/bin/python3 ${CMAKE_CURRENT_SOURCE_DIR}/modbus_mbpoll_test.py ${PROJECT_BINARY_DIR})
set_tests_properties(modbus_mbpoll_test PROPERTIES LABELS integration TIMEOUT 60)
