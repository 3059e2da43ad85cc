# CAN emulators: `guideway-emulate dbb`. The emulator itself is a static library so tests run it in-process.
add_library(guideway_emu_dbb STATIC ${CMAKE_CURRENT_LIST_DIR}/dbb_emulator.cpp ${CMAKE_CURRENT_LIST_DIR}/canopen_node.cpp ${CMAKE_CURRENT_LIST_DIR}/can_serial_control.cpp)
target_link_libraries(guideway_emu_dbb PUBLIC guideway_dbb guideway_can guideway_core PRIVATE guideway_warnings)
target_sources(guideway_emulators PRIVATE ${CMAKE_CURRENT_LIST_DIR}/dbb_command.cpp)
target_link_libraries(guideway_emulators PUBLIC guideway_emu_dbb)
# The virtual machine moved by LinuxCNC's servo periods (dbb --follow).
add_library(guideway_emu_linuxcnc STATIC ${CMAKE_CURRENT_LIST_DIR}/linuxcnc_follower.cpp)
target_link_libraries(guideway_emu_linuxcnc PUBLIC guideway_emu_dbb guideway_machine guideway_linuxcnc
  PRIVATE guideway_emu_can_serial_sources guideway_warnings)
target_link_libraries(guideway_emulators PUBLIC guideway_emu_linuxcnc)
