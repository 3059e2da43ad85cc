# `guideway ports`: serial port discovery through libserialport (drivers/serial).
target_sources(guideway PRIVATE ${CMAKE_CURRENT_LIST_DIR}/ports_commands.cpp)
target_link_libraries(guideway PRIVATE guideway_serial nlohmann_json::nlohmann_json)
