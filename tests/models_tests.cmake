# Tests of the virtual machine tool and the identification models (DBB).
guideway_add_test(machine_test SOURCES machine_test.cpp LIBS guideway_machine)
guideway_add_test(dbb_lai_test SOURCES dbb_lai_test.cpp LIBS guideway_dbb_sim)
guideway_add_test(dbb_diagnostics_test SOURCES dbb_diagnostics_test.cpp LIBS guideway_dbb_sim)
guideway_add_test(dbb_run_test SOURCES dbb_run_test.cpp LIBS guideway_model_dbb)
guideway_add_test(dbb_arcs_test SOURCES dbb_arcs_test.cpp LIBS guideway_dbb_sim guideway_explain_model)
# Gaps near a reversal: precision lost, no bias; the same over 20 seeds is `slow`.
guideway_add_test(dbb_gaps_test SOURCES dbb_gaps_test.cpp LIBS guideway_dbb_sim)
add_test(NAME dbb_gaps_seeds COMMAND dbb_gaps_test --gtest_filter=DbbGapsTest.SeedsStatistics)
set_tests_properties(dbb_gaps_seeds PROPERTIES LABELS slow TIMEOUT 600 ENVIRONMENT GUIDEWAY_SLOW_TESTS=1)
guideway_add_test(dbb_lsq_test SOURCES dbb_lsq_test.cpp LIBS guideway_model_dbb)
# Its three parts as tests of their own: each identifies with EXPLAIN, which a sanitizer slows most.
# 240 s: three_planes took 32 s under clang ASan on a slow day and 71 s beside two CPU hogs (59 % of the
# 120 s it had, which fails the stage's margin check).
foreach(part basic three_planes six_effects)
  add_test(NAME dbb_cli_test-${part}
    COMMAND /usr/bin/python3 ${CMAKE_CURRENT_SOURCE_DIR}/dbb_cli_test.py ${PROJECT_BINARY_DIR} ${PROJECT_SOURCE_DIR} ${part})
  set_tests_properties(dbb_cli_test-${part} PROPERTIES LABELS integration TIMEOUT 240)
endforeach()
# EXPLAIN on simulated runs in most cases, 26 s in Release and six times that under ASan: its heaviest
# cases in groups of their own (7, 7, 5, 2.4 s in Release), the rest together (about 6 s; 71 s under ASan
# before leadscrew had its own group). 180 s: the set-aside case
# alone is over 40 s under ASan on two cores.
guideway_add_test(compensation_test SOURCES compensation_test.cpp LIBS guideway_model_compensation guideway_explain_model
  guideway_dbb_sim guideway_formats TIMEOUT 180 GROUPS
  set_aside=CompensationCheckedTest.EffectsFoundBesideASetAsidePlaceAreFittedBeside
  several_effects=*CompensationVerifyTest.TablesCutGAndLeaveCompensatedTermsInTheNoise/machine_several_effects
  spikes=CompensationVerifyTest.SpikesAfterABacklashTableAreTheTablesStepNotStiction:*CompensationVerifyTest.*/machine_example
  leadscrew=*CompensationVerifyTest.*/machine_leadscrew)
add_test(NAME compensate_cli_test COMMAND /usr/bin/python3 ${CMAKE_CURRENT_SOURCE_DIR}/compensate_cli_test.py ${PROJECT_BINARY_DIR} ${PROJECT_SOURCE_DIR})
set_tests_properties(compensate_cli_test PROPERTIES LABELS integration TIMEOUT 300)
add_test(NAME compensate_lai_cli_test COMMAND /usr/bin/python3 ${CMAKE_CURRENT_SOURCE_DIR}/compensate_lai_cli_test.py ${PROJECT_BINARY_DIR} ${PROJECT_SOURCE_DIR})
set_tests_properties(compensate_lai_cli_test PROPERTIES LABELS integration TIMEOUT 300)
guideway_add_test(dbb_explain_agreement_test SOURCES dbb_explain_agreement_test.cpp LIBS guideway_dbb_sim guideway_explain_model)
# The demo's gappy live session (tests/data/demo_gaps) against its machine file and numpy.
add_test(NAME dbb_gaps_cli_test COMMAND /usr/bin/python3 ${CMAKE_CURRENT_SOURCE_DIR}/dbb_gaps_cli_test.py ${PROJECT_BINARY_DIR} ${PROJECT_SOURCE_DIR})
set_tests_properties(dbb_gaps_cli_test PROPERTIES LABELS integration TIMEOUT 120)
