# `guideway identify artifact` (models/artifact, Wei 2019).
target_sources(guideway PRIVATE ${CMAKE_CURRENT_LIST_DIR}/artifact_commands.cpp)
target_link_libraries(guideway PRIVATE guideway_artifact_model)
