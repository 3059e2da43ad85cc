# dsp: wavelets, streaming, denoising, correlation. Reference data from PyWavelets/numpy under /usr/bin/python3.
add_executable(dsp_reference_tool ${CMAKE_CURRENT_LIST_DIR}/dsp_reference_tool.cpp)
target_link_libraries(dsp_reference_tool PRIVATE guideway_dsp nlohmann_json::nlohmann_json guideway_warnings)
target_compile_options(dsp_reference_tool PRIVATE -ffp-contract=off)
add_test(NAME dsp_reference_test
  COMMAND /usr/bin/python3 ${CMAKE_CURRENT_LIST_DIR}/dsp_reference_test.py $<TARGET_FILE:dsp_reference_tool>)
set_tests_properties(dsp_reference_test PROPERTIES LABELS unit TIMEOUT 300)
