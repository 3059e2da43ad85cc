# `guideway explain` (models/explain): explain the mismatch; the scenario suite and its table.
target_sources(guideway PRIVATE ${CMAKE_CURRENT_LIST_DIR}/explain_commands.cpp)
target_link_libraries(guideway PRIVATE guideway_explain_model guideway_explain_scenarios guideway_model_dbb)
