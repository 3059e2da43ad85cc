# DBB identification: three 3600-point patterns (bench/README.md, "DBB identification").
add_executable(dbb_bench ${CMAKE_CURRENT_LIST_DIR}/dbb_bench.cpp)
target_link_libraries(dbb_bench PRIVATE guideway_dbb_sim benchmark::benchmark guideway_warnings)
