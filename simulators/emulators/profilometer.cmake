# Emulated profilometer (PGI 1240-style profile stream on TCP): `guideway-emulate profilometer`.
# Traverses come from the virtual machine tool (profilometer_machine_source: faced-workpiece profiles).
add_library(guideway_profilometer_emulator STATIC ${CMAKE_CURRENT_LIST_DIR}/profilometer_emulator.cpp
                                                  ${CMAKE_CURRENT_LIST_DIR}/profilometer_machine_source.cpp)
target_link_libraries(guideway_profilometer_emulator PUBLIC guideway_profilometer guideway_micrometer_emulator guideway_machine guideway_core
                      PRIVATE guideway_warnings)
target_sources(guideway_emulators PRIVATE ${CMAKE_CURRENT_LIST_DIR}/profilometer_command.cpp)
target_link_libraries(guideway_emulators PUBLIC guideway_profilometer_emulator)
