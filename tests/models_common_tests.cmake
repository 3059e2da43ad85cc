# models/common: the Householder triangle behind solve_lsq (numpy, Eigen, SSE2 vs AVX2 bit for bit).
guideway_add_test(lsq_triangle_test SOURCES lsq_triangle_test.cpp LIBS guideway_models_common LABELS unit)
# A line's amplitude and phase with u from its parts' covariance (numpy's propagation as the oracle).
guideway_add_test(amplitude_phase_test SOURCES amplitude_phase_test.cpp LIBS guideway_models_common LABELS unit)
