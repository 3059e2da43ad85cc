# The Debian package, built by CPack from this tree and read back with dpkg-deb and lintian (a peer's checks:
# the Release stage only, as a packager builds it).
add_test(NAME package_test
  COMMAND /usr/bin/python3 ${CMAKE_CURRENT_SOURCE_DIR}/package_test.py ${PROJECT_BINARY_DIR} ${PROJECT_SOURCE_DIR})
set_tests_properties(package_test PROPERTIES LABELS "integration;peer" TIMEOUT 400 SKIP_RETURN_CODE 77)
