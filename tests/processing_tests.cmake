# The daemon's [[processing]] steps (online wavelet denoising of a channel).
guideway_add_test(processing_test SOURCES processing_test.cpp LIBS guideway_daemon LABELS unit)
