# The I/O loop that serves every loop-driven device (drivers/io_loop.hpp): alone, and with real
# drivers sharing it as in guidewayd (a flooding device, the four instruments' faults).
guideway_add_test(io_loop_test SOURCES io_loop_test.cpp
  LIBS guideway_dbb guideway_autocollimator guideway_micrometer guideway_profilometer guideway_emu_can_serial_sources
       guideway_micrometer_emulator guideway_profilometer_emulator
  LABELS integration tsan TIMEOUT 120)
# The TCP connection attempt the loop-driven TCP drivers share.
guideway_add_test(tcp_loop_connector_test SOURCES tcp_loop_connector_test.cpp LIBS guideway_tcp
  LABELS unit TIMEOUT 60)
# The back-off between a lost device's connection attempts, shared by the drivers.
guideway_add_test(reconnect_backoff_test SOURCES reconnect_backoff_test.cpp LIBS guideway_drivers
  LABELS unit TIMEOUT 30)
