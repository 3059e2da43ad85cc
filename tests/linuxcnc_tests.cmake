# The peer Guideway's compensation tables are for: LinuxCNC itself (Debian's linuxcnc-uspace, installed by
# scripts/setup.sh) loads the tables `guideway compensate dbb` writes and applies them. One LinuxCNC per
# machine: RESOURCE_LOCK keeps ctest from starting it twice (the test also locks across checkouts).
add_test(NAME linuxcnc_comp_test
  COMMAND /usr/bin/python3 ${CMAKE_CURRENT_SOURCE_DIR}/linuxcnc_comp_test.py ${PROJECT_BINARY_DIR} ${PROJECT_SOURCE_DIR})
set_tests_properties(linuxcnc_comp_test PROPERTIES LABELS "integration;peer" TIMEOUT 300 SKIP_RETURN_CODE 77
  RESOURCE_LOCK linuxcnc)

# The bridge's pieces without LinuxCNC: its stream, the bridge on a stand-in for halsampler, the follower's
# playback, the machine stepped by servo periods, the test program's G-code.
guideway_add_test(linuxcnc_bridge_test SOURCES linuxcnc_bridge_test.cpp
                  LIBS guideway_linuxcnc guideway_emu_linuxcnc guideway_machine guideway_formats)

# guidewayd's linuxcnc-hal device and [[session_trigger]] on the bridge fed by a stand-in for halsampler: the
# program's pin begins and ends a DBB session, every servo period counted (lost ones too).
add_test(NAME linuxcnc_session_trigger_test
  COMMAND /usr/bin/python3 ${CMAKE_CURRENT_SOURCE_DIR}/linuxcnc_session_trigger_test.py ${PROJECT_BINARY_DIR})
set_tests_properties(linuxcnc_session_trigger_test PROPERTIES LABELS integration TIMEOUT 120)

# LinuxCNC in the loop, headless (scripts/linuxcnc_loop.py): G after < G before / 3, no servo period lost, the
# tables and external offsets LinuxCNC applied equal to the files; skipped where LinuxCNC cannot start.
add_test(NAME linuxcnc_loop_test
  COMMAND /usr/bin/python3 ${CMAKE_CURRENT_SOURCE_DIR}/linuxcnc_loop_test.py ${PROJECT_BINARY_DIR} ${PROJECT_SOURCE_DIR})
set_tests_properties(linuxcnc_loop_test PROPERTIES LABELS "integration;peer" TIMEOUT 600 SKIP_RETURN_CODE 77
  RESOURCE_LOCK linuxcnc)
