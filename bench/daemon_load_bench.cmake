# Daemon load and latency (bench/README.md, "Daemon load and latency"): guidewayd with the four
# emulators at rising rates and 100 watching clients. Not a test: run it on a quiet machine with
#   cmake --build BUILD --target daemon_load_bench
# (about 3 minutes; results also in BUILD/bench/daemon_load.json).
add_custom_target(daemon_load_bench
  COMMAND python3 ${CMAKE_CURRENT_LIST_DIR}/daemon_load.py ${PROJECT_BINARY_DIR}
          --json ${CMAKE_CURRENT_BINARY_DIR}/daemon_load.json
  USES_TERMINAL
  COMMENT "guidewayd load and latency benchmark")
add_dependencies(daemon_load_bench guidewayd guideway-emulate)
