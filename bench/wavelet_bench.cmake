# Wavelets: batch wavedec/waverec/MRA and streaming (bench/README.md, "Wavelets"; bench/wavelet_vs_pywt.py).
add_executable(wavelet_bench ${CMAKE_CURRENT_LIST_DIR}/wavelet_bench.cpp)
target_link_libraries(wavelet_bench PRIVATE guideway_dsp benchmark::benchmark guideway_warnings)
