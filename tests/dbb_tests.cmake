# DBB identification helpers (the model's own tests are in models_tests.cmake).
guideway_add_test(dbb_fast_sincos_test SOURCES dbb_fast_sincos_test.cpp LIBS guideway_model_dbb)
guideway_add_test(dbb_drive_track_test SOURCES dbb_drive_track_test.cpp LIBS guideway_model_dbb)
guideway_add_test(dbb_h_aliasing_test SOURCES dbb_h_aliasing_test.cpp LIBS guideway_dbb_sim)
# The standards' figures (ISO 230-4, ASME B5.54) and their test conditions, against numpy (docs/standards.md).
add_test(NAME standard_figures_test
  COMMAND /usr/bin/python3 ${CMAKE_CURRENT_SOURCE_DIR}/standard_figures_test.py ${PROJECT_BINARY_DIR}
          ${PROJECT_SOURCE_DIR})
set_tests_properties(standard_figures_test PROPERTIES LABELS integration TIMEOUT 120)
