# Serial emulators: `guideway-emulate autocollimator`. The emulator itself is a static library so tests
# run it in-process; the machine-driven sources of the CAN and serial emulators live here too.
add_library(guideway_emu_autocollimator STATIC ${CMAKE_CURRENT_LIST_DIR}/autocollimator_emulator.cpp)
target_link_libraries(guideway_emu_autocollimator PUBLIC guideway_autocollimator guideway_serial guideway_core
                      PRIVATE guideway_warnings)
add_library(guideway_emu_can_serial_sources STATIC ${CMAKE_CURRENT_LIST_DIR}/can_serial_machine_sources.cpp)
target_link_libraries(guideway_emu_can_serial_sources PUBLIC guideway_emu_dbb guideway_emu_autocollimator
                      guideway_machine PRIVATE guideway_warnings)
target_sources(guideway_emulators PRIVATE ${CMAKE_CURRENT_LIST_DIR}/autocollimator_command.cpp)
target_link_libraries(guideway_emulators PUBLIC guideway_emu_autocollimator guideway_emu_can_serial_sources)
