# plant/ (MQTT topic tree, broker address, journal, publisher) and the daemon publishing to a real broker.
guideway_add_test(plant_test SOURCES plant_test.cpp LIBS guideway_plant)
add_test(NAME mqtt_daemon_test COMMAND /usr/bin/python3 ${CMAKE_CURRENT_SOURCE_DIR}/mqtt_daemon_test.py ${PROJECT_BINARY_DIR})
set_tests_properties(mqtt_daemon_test PROPERTIES LABELS integration TIMEOUT 300 SKIP_RETURN_CODE 77)
guideway_add_test(publisher_test SOURCES publisher_test.cpp LIBS guideway_plant LABELS integration tsan)
# ./scripts/plant_demo.sh as a newcomer runs it (builds the checkout's build/, two daemons for a minute).
add_test(NAME plant_demo_test COMMAND /usr/bin/python3 ${CMAKE_CURRENT_SOURCE_DIR}/plant_demo_test.py ${PROJECT_SOURCE_DIR})
# Started early (COST): most of its minute is waiting on paced sessions, beside the other tests; it
# configures the checkout's build/ as readme_demo_rerun_test does, so never beside it (RESOURCE_LOCK).
set_tests_properties(plant_demo_test PROPERTIES LABELS slow TIMEOUT 900 COST 950 RESOURCE_LOCK checkout_build)
