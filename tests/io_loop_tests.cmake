# The I/O loop that serves every loop-driven device (drivers/io_loop.hpp): alone, and with real
# drivers sharing it as in guidewayd (a flooding device, the four instruments' faults).
guideway_add_test(io_loop_test SOURCES io_loop_test.cpp
  LIBS guideway_dbb guideway_autocollimator guideway_micrometer guideway_profilometer guideway_emu_can_serial_sources
       guideway_micrometer_emulator guideway_profilometer_emulator
  LABELS integration tsan TIMEOUT 120)
# The TCP connection attempt the loop-driven TCP drivers share.
guideway_add_test(tcp_loop_connector_test SOURCES tcp_loop_connector_test.cpp LIBS guideway_tcp
  LABELS unit TIMEOUT 60)
# The back-off between retries (core/backoff.hpp): the drivers' connection attempts, the broker's, the emulators'.
guideway_add_test(backoff_test SOURCES backoff_test.cpp LIBS guideway_core
  LABELS unit TIMEOUT 30)
# The one rule of `streaming` for every built-in driver: a peer that sends junk, one that stays silent.
guideway_add_test(driver_streaming_rule_test SOURCES driver_streaming_rule_test.cpp
  LIBS guideway_dbb guideway_autocollimator guideway_micrometer guideway_profilometer LABELS integration tsan TIMEOUT 60)
