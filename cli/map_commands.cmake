# `guideway map` (fit, export, volumetric, sequence) and `guideway simulate day`
# (models/map: the 21 errors from a day's tests; docs/map.md).
target_sources(guideway PRIVATE ${CMAKE_CURRENT_LIST_DIR}/map_commands.cpp ${CMAKE_CURRENT_LIST_DIR}/map_support.cpp
  ${CMAKE_CURRENT_LIST_DIR}/map_sequence.cpp)
target_link_libraries(guideway PRIVATE guideway_map_model guideway_map_truth guideway_measurement_files guideway_report
  guideway_dbb_sim guideway_formats)
