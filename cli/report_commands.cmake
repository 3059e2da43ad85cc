# `guideway report` (report/).
target_sources(guideway PRIVATE ${CMAKE_CURRENT_LIST_DIR}/report_commands.cpp)
target_link_libraries(guideway PRIVATE guideway_report)
