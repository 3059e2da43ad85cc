# Offline measurement files from the virtual machine tool (no transport): `guideway-emulate workpiece`
# (Mu's faced-workpiece experiment) and `guideway-emulate artifact` (Wei's 1-D artifact).
add_library(guideway_measurement_files STATIC ${CMAKE_CURRENT_LIST_DIR}/measurement_files.cpp)
target_link_libraries(guideway_measurement_files PUBLIC guideway_machine guideway_core
                      PRIVATE guideway_formats guideway_warnings)
target_sources(guideway_emulators PRIVATE ${CMAKE_CURRENT_LIST_DIR}/measurement_files_command.cpp)
target_link_libraries(guideway_emulators PUBLIC guideway_measurement_files)
