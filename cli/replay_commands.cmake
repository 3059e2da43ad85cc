# `guideway replay`: links the daemon's session code so a replay runs exactly what guidewayd ran.
target_sources(guideway PRIVATE ${CMAKE_CURRENT_LIST_DIR}/replay_commands.cpp)
target_link_libraries(guideway PRIVATE guideway_daemon)
