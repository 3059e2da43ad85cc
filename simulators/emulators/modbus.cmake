# Emulated inductance micrometer (gauge amplifier) on Modbus TCP / RTU: `guideway-emulate micrometer`.
# Values come from the virtual machine tool (micrometer_machine_source: spindle run-out on a thrust plate).
add_library(guideway_micrometer_emulator STATIC ${CMAKE_CURRENT_LIST_DIR}/modbus_emulator.cpp
                                                ${CMAKE_CURRENT_LIST_DIR}/micrometer_machine_source.cpp)
target_link_libraries(guideway_micrometer_emulator PUBLIC guideway_modbus guideway_machine guideway_core
                      PRIVATE guideway_warnings)
target_sources(guideway_emulators PRIVATE ${CMAKE_CURRENT_LIST_DIR}/micrometer_command.cpp)
target_link_libraries(guideway_emulators PUBLIC guideway_micrometer_emulator)
