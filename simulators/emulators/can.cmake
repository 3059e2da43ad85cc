# CAN emulators: `guideway-emulate dbb`. The emulator itself is a static library so tests run it in-process.
add_library(guideway_emu_dbb STATIC ${CMAKE_CURRENT_LIST_DIR}/dbb_emulator.cpp ${CMAKE_CURRENT_LIST_DIR}/canopen_node.cpp ${CMAKE_CURRENT_LIST_DIR}/can_serial_control.cpp)
target_link_libraries(guideway_emu_dbb PUBLIC guideway_dbb guideway_can guideway_core PRIVATE guideway_warnings)
target_sources(guideway_emulators PRIVATE ${CMAKE_CURRENT_LIST_DIR}/dbb_command.cpp)
target_link_libraries(guideway_emulators PUBLIC guideway_emu_dbb)
