# The raw recording format: writer bytes, reader, listing (formats/raw_recording.hpp).
guideway_add_test(raw_recording_test SOURCES raw_recording_test.cpp LIBS guideway_formats)
