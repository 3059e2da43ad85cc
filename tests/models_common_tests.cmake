# models/common: the Householder triangle behind solve_lsq (numpy, Eigen, SSE2 vs AVX2 bit for bit).
guideway_add_test(lsq_triangle_test SOURCES lsq_triangle_test.cpp LIBS guideway_models_common LABELS unit)
