# The straightness, runout and profile sessions (sessions/) (unit: fed with the virtual machine tool's
# data as their drivers deliver it), and end to end against guidewayd with its emulators, including
# a recording left by a daemon killed with SIGKILL.
guideway_add_test(daemon_sessions_test SOURCES daemon_sessions_test.cpp
  LIBS guideway_session_kinds guideway_machine guideway_flatness_models guideway_explain_model guideway_formats
  guideway_profilometer)
add_test(NAME e2e_sessions_test COMMAND /usr/bin/python3 ${CMAKE_CURRENT_SOURCE_DIR}/e2e_sessions_test.py ${PROJECT_BINARY_DIR})
set_tests_properties(e2e_sessions_test PROPERTIES LABELS integration TIMEOUT 400)
