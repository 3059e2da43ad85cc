# The machine's floor: CPU per timed wake-up and per CAN frame received, and each instrument's bare
# read on its transport with the drivers' own decoding, nothing of the daemon in the loop
# (bench/README.md, "The floor"). Run it beside daemon_load.py on the same machine.
add_executable(platform_floor_bench ${CMAKE_CURRENT_LIST_DIR}/platform_floor_bench.cpp)
target_link_libraries(platform_floor_bench PRIVATE benchmark::benchmark guideway_autocollimator guideway_modbus
                                                   guideway_profilometer guideway_tcp guideway_warnings)
