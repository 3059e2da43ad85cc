# `guideway compensate dbb` (models/compensation): compensation tables from a DBB identification, verified on
# the virtual machine tool.
target_sources(guideway PRIVATE ${CMAKE_CURRENT_LIST_DIR}/compensate_commands.cpp)
target_link_libraries(guideway PRIVATE guideway_model_compensation guideway_dbb_sim guideway_formats)
