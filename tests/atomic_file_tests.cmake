# core/atomic_file: whole files, and sets of files that are only right together.
guideway_add_test(atomic_file_test SOURCES atomic_file_test.cpp LIBS guideway_core LABELS unit)
