# Tests of report/: the SVG writer (structure, tick scaling, well-formed XML checked by Python's XML parser
# and the axis mapping recovered from the tick labels), the report sections and their errors, and the
# whole report in headless Chromium (console errors, axes/labels/data paths of every plot, screenshots and an
# A4 print-out kept in build/report_artifacts). Chromium missing is a failure: ./scripts/setup.sh installs it.
guideway_add_test(report_svg_test SOURCES report_svg_test.cpp LIBS guideway_report guideway_machine
  guideway_dbb_sim guideway_explain_scenarios LABELS unit)
add_executable(report_svg_tool report_svg_tool.cpp)
target_link_libraries(report_svg_tool PRIVATE guideway_report guideway_warnings)
add_test(NAME report_svg_xml_test
  COMMAND /usr/bin/python3 ${CMAKE_CURRENT_SOURCE_DIR}/report_svg_xml_test.py $<TARGET_FILE:report_svg_tool>)
set_tests_properties(report_svg_xml_test PROPERTIES LABELS unit TIMEOUT 60)
add_test(NAME report_chromium_test
  COMMAND /usr/bin/python3 ${CMAKE_CURRENT_SOURCE_DIR}/report_chromium_test.py $<TARGET_FILE:guideway>
          $<TARGET_FILE:guideway-emulate> ${PROJECT_SOURCE_DIR} ${PROJECT_SOURCE_DIR}/tests/data/moody1955
          ${PROJECT_BINARY_DIR}/report_artifacts)
set_tests_properties(report_chromium_test PROPERTIES LABELS integration TIMEOUT 180)
