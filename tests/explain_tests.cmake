# Tests of models/explain: statistics against scipy, the engine on synthetic problems, the scenario
# suite on the virtual machine tool (quick density; the full-density table is `slow`), and the CLI.
guideway_add_test(explain_stats_test SOURCES explain_stats_test.cpp LIBS guideway_explain_model LABELS unit)
guideway_add_test(explain_engine_test SOURCES explain_engine_test.cpp LIBS guideway_explain_model LABELS unit)
# The scenario table (every scenario once: 71 s under ASan on a slow day) apart from the other cases (32 s):
# together they were 35 % of the timeout there.
guideway_add_test(explain_scenarios_test SOURCES explain_scenarios_test.cpp LIBS guideway_explain_scenarios
  LABELS unit TIMEOUT 300 GROUPS table=All/ExplainScenario.*)
add_test(NAME explain_cli_test
  COMMAND /usr/bin/python3 ${CMAKE_CURRENT_SOURCE_DIR}/explain_cli_test.py $<TARGET_FILE:guideway> ${PROJECT_SOURCE_DIR})
set_tests_properties(explain_cli_test PROPERTIES LABELS integration TIMEOUT 300)
# The whole suite at the instrument's full sample density over seeds 1-5, as for docs/explain.md's table.
add_test(NAME explain_scenarios_full COMMAND $<TARGET_FILE:guideway> explain --scenarios --full --seeds 5)
set_tests_properties(explain_scenarios_full PROPERTIES LABELS slow TIMEOUT 1200 COST 800)
# The flatness front end with Mu Eq. 16's measured straightness and the abbe_offset term.
guideway_add_test(explain_profile_test SOURCES explain_profile_test.cpp LIBS guideway_explain_model guideway_machine LABELS unit)
# The effect library: one file per effect, each candidate of the front ends a library effect with its names
# in the catalogue of parameters.
guideway_add_test(explain_effects_test SOURCES explain_effects_test.cpp
  LIBS guideway_explain_model guideway_dbb_sim guideway_machine guideway_results LABELS unit)
# The run-out front end on the virtual machine's spindle (synchronous, asynchronous, growth, speed).
guideway_add_test(explain_runout_test SOURCES explain_runout_test.cpp LIBS guideway_explain_model guideway_machine LABELS unit)
# The traverse front end on the virtual machine's X carriage (drift, rocking, pitch wave, yaw coupling).
guideway_add_test(explain_traverse_test SOURCES explain_traverse_test.cpp
  LIBS guideway_explain_scenarios guideway_explain_model guideway_machine LABELS unit)
add_test(NAME explain_traverse_cli_test
  COMMAND /usr/bin/python3 ${CMAKE_CURRENT_SOURCE_DIR}/explain_traverse_cli_test.py $<TARGET_FILE:guideway>
          $<TARGET_FILE:guideway-emulate>)
set_tests_properties(explain_traverse_cli_test PROPERTIES LABELS integration TIMEOUT 120)
# Real DABAM slope profiles through `explain --model traverse`: one pass each, no finding on a profile alone,
# the instruments' ranges.
add_test(NAME dabam_explain_cli_test
  COMMAND /usr/bin/python3 ${CMAKE_CURRENT_SOURCE_DIR}/dabam_explain_cli_test.py $<TARGET_FILE:guideway>
          ${PROJECT_SOURCE_DIR}/tests/data/dabam)
set_tests_properties(dabam_explain_cli_test PROPERTIES LABELS integration TIMEOUT 120)
# EXPLAIN's scenarios on real backgrounds (issue 41 item 9): real flats of tests/data/dabam as forward and return
# passes, alone, with a rocking, and with a rocking and a settling after the reversal. Three small flats, each
# judged, everywhere (2.7 s of CPU in Release, 25 s under ASan); the twelve flats' rates, docs/explain.md's table, in
# Release only (`slow`: 2 s of CPU since the term per station is fitted out of the readings; 130 s for ten flats as
# columns).
add_test(NAME dabam_scenarios_test
  COMMAND /usr/bin/python3 ${CMAKE_CURRENT_SOURCE_DIR}/dabam_scenarios_test.py $<TARGET_FILE:guideway>
          ${PROJECT_SOURCE_DIR}/tests/data/dabam --quick)
set_tests_properties(dabam_scenarios_test PROPERTIES LABELS integration TIMEOUT 180)
add_test(NAME dabam_scenarios_full
  COMMAND /usr/bin/python3 ${CMAKE_CURRENT_SOURCE_DIR}/dabam_scenarios_test.py $<TARGET_FILE:guideway>
          ${PROJECT_SOURCE_DIR}/tests/data/dabam)
set_tests_properties(dabam_scenarios_full PROPERTIES LABELS slow TIMEOUT 900 COST 20)
