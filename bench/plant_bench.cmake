# Plant scale (bench/README.md, "Plant: MQTT publishers into one broker and one fleet"): N publishers
# speaking the daemon's exact publisher code (plant::Publisher) in one process, into a broker.
# bench/plant_load.py runs it with mosquitto and `guideway fleet serve`, then guidewayd with MQTT off
# and on:   cmake --build BUILD --target plant_load_bench
add_executable(plant_publishers ${CMAKE_CURRENT_LIST_DIR}/plant_publishers.cpp)
target_link_libraries(plant_publishers PRIVATE guideway_plant guideway_results nlohmann_json::nlohmann_json guideway_warnings)
target_compile_definitions(plant_publishers PRIVATE GUIDEWAY_SOURCE_DIR="${PROJECT_SOURCE_DIR}")
add_custom_target(plant_load_bench
  COMMAND python3 ${CMAKE_CURRENT_LIST_DIR}/plant_load.py ${PROJECT_BINARY_DIR}
          --json ${CMAKE_CURRENT_BINARY_DIR}/plant_load.json
  USES_TERMINAL
  COMMENT "50 MQTT publishers into one broker and one fleet; guidewayd with MQTT off and on")
add_dependencies(plant_load_bench plant_publishers guidewayd guideway-emulate guideway)
# A smoke run (about 5 s: 3 publishers x 6 messages, 1 s per guidewayd step), so that the benchmark
# keeps working; its figures mean nothing.
if(GUIDEWAY_BUILD_TESTS)
  add_test(NAME plant_load_smoke
           COMMAND /usr/bin/python3 ${CMAKE_CURRENT_LIST_DIR}/plant_load.py ${PROJECT_BINARY_DIR} --publishers 3
                   --messages 6 --rate-hz 0 --step-s 1 --warmup-s 0.5 --rounds 1)
  set_tests_properties(plant_load_smoke PROPERTIES LABELS integration TIMEOUT 120 SKIP_REGULAR_EXPRESSION "skipped")
endif()
