# `guideway linuxcnc offsets`: the squareness and straightness of a compensation directory as LinuxCNC's
# external offsets through HAL (formats/linuxcnc_offsets).
target_sources(guideway PRIVATE ${CMAKE_CURRENT_LIST_DIR}/linuxcnc_commands.cpp)
target_link_libraries(guideway PRIVATE guideway_formats guideway_core)
