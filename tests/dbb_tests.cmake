# DBB identification helpers (the model's own tests are in models_tests.cmake).
guideway_add_test(dbb_fast_sincos_test SOURCES dbb_fast_sincos_test.cpp LIBS guideway_model_dbb)
guideway_add_test(dbb_h_aliasing_test SOURCES dbb_h_aliasing_test.cpp LIBS guideway_dbb_sim)
