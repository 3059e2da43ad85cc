# EXPLAIN's held-out RMS with the variants re-chosen in every fold (nested) against the variants chosen
# on all the data kept: size of the optimism and the CPU cost (docs/explain.md "Held out").
add_executable(explain_heldout_bench ${CMAKE_CURRENT_LIST_DIR}/explain_heldout_bench.cpp)
target_link_libraries(explain_heldout_bench PRIVATE guideway_explain_scenarios guideway_warnings)

# EXPLAIN's CPU against the samples per run (bench/README.md "EXPLAIN's cost").
add_executable(explain_cost_bench ${CMAKE_CURRENT_LIST_DIR}/explain_cost_bench.cpp)
target_link_libraries(explain_cost_bench PRIVATE guideway_explain_scenarios benchmark::benchmark guideway_warnings)

# The input files of bench/explain_footprint.py: the cases of issue 45's table (bench/README.md "EXPLAIN's
# footprint").
add_executable(explain_footprint_cases ${CMAKE_CURRENT_LIST_DIR}/explain_footprint_cases.cpp)
target_link_libraries(explain_footprint_cases PRIVATE guideway_explain_scenarios guideway_machine guideway_formats
  guideway_warnings)
