# The daemon's [[processing]] steps (online wavelet denoising of a channel).
guideway_add_test(processing_test SOURCES processing_test.cpp LIBS guideway_daemon LABELS unit)
# Replay: golden recordings (tests/golden, recorded live from the emulators) replay to the PARAMS the
# live sessions published. Regenerate after an intended change of identification:
#   /usr/bin/python3 tests/replay_golden_test.py build/cli/guideway tests/golden --regenerate
add_test(NAME replay_golden_test
  COMMAND /usr/bin/python3 ${CMAKE_CURRENT_SOURCE_DIR}/replay_golden_test.py $<TARGET_FILE:guideway>
          ${CMAKE_CURRENT_SOURCE_DIR}/golden)
set_tests_properties(replay_golden_test PROPERTIES LABELS integration TIMEOUT 300)
