# The pipeline's wake-up path (bench/README.md, "Daemon load and latency").
guideway_add_test(doorbell_test SOURCES doorbell_test.cpp LIBS guideway_drivers LABELS unit tsan)
guideway_add_test(socket_server_batch_test SOURCES socket_server_batch_test.cpp LIBS guideway_daemon)
