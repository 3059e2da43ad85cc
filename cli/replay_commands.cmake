# `guideway replay`: links the session code guidewayd runs (guideway_session_kinds), so a replay runs exactly
# what the daemon ran.
target_sources(guideway PRIVATE ${CMAKE_CURRENT_LIST_DIR}/replay_commands.cpp)
target_link_libraries(guideway PRIVATE guideway_session_kinds)
