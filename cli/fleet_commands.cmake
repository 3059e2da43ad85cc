# `guideway fleet serve|status|history|report|ingest` (fleet/): the plant's view of every machine from the
# fleet database that `guideway fleet serve` fills from the MQTT broker (docs/plant.md).
target_sources(guideway PRIVATE ${CMAKE_CURRENT_LIST_DIR}/fleet_commands.cpp)
target_link_libraries(guideway PRIVATE guideway_fleet guideway_plant)
