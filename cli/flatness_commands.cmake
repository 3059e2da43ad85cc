# `guideway identify straightness|unionjack|runout|flatness` (models/flatness).
target_sources(guideway PRIVATE ${CMAKE_CURRENT_LIST_DIR}/flatness_commands.cpp)
target_link_libraries(guideway PRIVATE guideway_flatness_models)
