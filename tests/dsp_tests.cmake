# dsp: wavelets, streaming, denoising, correlation. Reference data from PyWavelets/numpy under /usr/bin/python3.
add_executable(dsp_reference_tool ${CMAKE_CURRENT_LIST_DIR}/dsp_reference_tool.cpp)
target_link_libraries(dsp_reference_tool PRIVATE guideway_dsp nlohmann_json::nlohmann_json guideway_warnings)
target_compile_options(dsp_reference_tool PRIVATE -ffp-contract=off)
add_test(NAME dsp_reference_test
  COMMAND /usr/bin/python3 ${CMAKE_CURRENT_LIST_DIR}/dsp_reference_test.py $<TARGET_FILE:dsp_reference_tool>)
set_tests_properties(dsp_reference_test PROPERTIES LABELS unit TIMEOUT 300)
guideway_add_test(dsp_streaming_test SOURCES ${CMAKE_CURRENT_LIST_DIR}/dsp_streaming_test.cpp LIBS guideway_dsp LABELS unit)
target_compile_options(dsp_streaming_test PRIVATE -ffp-contract=off)
# Its own floating-point option: the tests' shared precompiled header (built without it) is not for it.
set_target_properties(dsp_streaming_test PROPERTIES DISABLE_PRECOMPILE_HEADERS ON)
guideway_add_test(dsp_wavelet_test SOURCES ${CMAKE_CURRENT_LIST_DIR}/dsp_wavelet_test.cpp LIBS guideway_dsp LABELS unit)
guideway_add_test(dsp_correlation_test SOURCES ${CMAKE_CURRENT_LIST_DIR}/dsp_correlation_test.cpp LIBS guideway_dsp LABELS unit)
guideway_add_test(dsp_series_test SOURCES ${CMAKE_CURRENT_LIST_DIR}/dsp_series_test.cpp LIBS guideway_dsp LABELS unit)
add_test(NAME dsp_x3p_test
  COMMAND /usr/bin/python3 ${CMAKE_CURRENT_LIST_DIR}/dsp_x3p_test.py $<TARGET_FILE:dsp_reference_tool>
          ${PROJECT_SOURCE_DIR}/tests/data/x3p/sample-land.x3p)
set_tests_properties(dsp_x3p_test PROPERTIES LABELS unit TIMEOUT 120)
add_test(NAME dsp_cli_test COMMAND /usr/bin/python3 ${CMAKE_CURRENT_LIST_DIR}/dsp_cli_test.py $<TARGET_FILE:guideway>)
set_tests_properties(dsp_cli_test PROPERTIES LABELS unit TIMEOUT 120)
guideway_add_test(dsp_csv_table_test SOURCES ${CMAKE_CURRENT_LIST_DIR}/dsp_csv_table_test.cpp LIBS guideway_core LABELS unit)
