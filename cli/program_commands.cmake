# `guideway program dbb`: the G-code of a ballbar test for the controller (formats/dbb_program).
target_sources(guideway PRIVATE ${CMAKE_CURRENT_LIST_DIR}/program_commands.cpp)
target_link_libraries(guideway PRIVATE guideway_formats)
