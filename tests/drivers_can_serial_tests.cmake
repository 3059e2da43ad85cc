# CAN (dbb-can) and serial (autocollimator-serial) drivers, their transports, parsers and emulators.
guideway_add_test(dbb_driver_test SOURCES dbb_driver_test.cpp LIBS guideway_dbb guideway_emu_dbb
                  LABELS integration tsan TIMEOUT 180)
