# Offline measurement files from the virtual machine tool (no transport): `guideway-emulate workpiece`
# (Mu's faced-workpiece experiment), `guideway-emulate artifact` (Wei's 1-D artifact on any axis) and a day's
# tests of the error map (`guideway simulate day`, day_files).
add_library(guideway_measurement_files STATIC ${CMAKE_CURRENT_LIST_DIR}/measurement_files.cpp
  ${CMAKE_CURRENT_LIST_DIR}/day_files.cpp)
target_link_libraries(guideway_measurement_files PUBLIC guideway_machine guideway_core
                      PRIVATE guideway_formats guideway_artifact_model guideway_flatness_models guideway_dbb_sim
                      nlohmann_json::nlohmann_json guideway_warnings)
target_sources(guideway_emulators PRIVATE ${CMAKE_CURRENT_LIST_DIR}/measurement_files_command.cpp)
target_link_libraries(guideway_emulators PUBLIC guideway_measurement_files)
