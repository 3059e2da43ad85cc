# `guideway compensate map` (models/map): the error map's controller tables, verified on the virtual machine tool.
target_sources(guideway PRIVATE ${CMAKE_CURRENT_LIST_DIR}/compensate_map_commands.cpp)
target_link_libraries(guideway PRIVATE guideway_map_model guideway_map_truth guideway_dbb_sim guideway_formats)
