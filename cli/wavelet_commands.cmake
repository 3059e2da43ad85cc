# `guideway wavelet ...` and `guideway correlate` (dsp).
target_sources(guideway PRIVATE ${CMAKE_CURRENT_LIST_DIR}/wavelet_commands.cpp)
target_link_libraries(guideway PRIVATE guideway_dsp)
