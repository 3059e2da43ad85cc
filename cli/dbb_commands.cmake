# `guideway identify dbb`, `guideway simulate dbb`.
target_sources(guideway PRIVATE ${CMAKE_CURRENT_LIST_DIR}/dbb_commands.cpp)
target_link_libraries(guideway PRIVATE guideway_model_dbb guideway_explain_model guideway_dbb_sim)
