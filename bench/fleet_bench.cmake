# The fleet database: ingest rate and `fleet status` on 50 machines x 100 results (bench/README.md, "Fleet").
add_executable(fleet_bench ${CMAKE_CURRENT_LIST_DIR}/fleet_bench.cpp)
target_link_libraries(fleet_bench PRIVATE guideway_fleet benchmark::benchmark guideway_warnings)
target_compile_definitions(fleet_bench PRIVATE GUIDEWAY_SOURCE_DIR="${PROJECT_SOURCE_DIR}")
