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
