# The Debian package of Guideway (CPack DEB; scripts/package.sh builds it, tests/packaging/package_test.py checks it,
# docs/linuxcnc.md "Installing"): the programs, their man pages, the systemd units with their sysusers.d and
# tmpfiles.d files, the default configuration (a conffile), the LinuxCNC files and the loop demo, the virtual
# machine files, the documentation. Any build tree packages (CPack installs it with the prefix /usr into a
# staging DESTDIR); scripts/package.sh configures one with that prefix so the compiled-in paths agree too.
set(GUIDEWAY_SHARE_DIR ${CMAKE_INSTALL_DATADIR}/guideway)
set(GUIDEWAY_DOC_DIR ${CMAKE_INSTALL_DATADIR}/doc/guideway)

# LinuxCNC: the bridge's HAL lines, the virtual machine's configuration, the headless DISPLAY, the loop.
install(FILES linuxcnc/guideway-bridge.hal DESTINATION ${GUIDEWAY_SHARE_DIR}/linuxcnc)
install(PROGRAMS linuxcnc/guideway_headless.py scripts/linuxcnc_loop.py scripts/linuxcnc_demo.sh
        DESTINATION ${GUIDEWAY_SHARE_DIR}/linuxcnc)
install(FILES linuxcnc/sim/guideway-sim.ini linuxcnc/sim/guideway-sim.hal DESTINATION ${GUIDEWAY_SHARE_DIR}/linuxcnc/sim)
install(FILES config/machine-example.toml config/machine-leadscrew.toml config/machine-several-effects.toml
        DESTINATION ${GUIDEWAY_SHARE_DIR})
install(FILES config/devices-can-serial.example.toml config/devices-modbus-profile.example.toml
        systemd/99-guideway-instruments.rules DESTINATION ${GUIDEWAY_DOC_DIR}/examples)
file(GLOB guideway_docs ${PROJECT_SOURCE_DIR}/docs/*.md)
install(FILES README.md ${guideway_docs} DESTINATION ${GUIDEWAY_DOC_DIR})
install(FILES packaging/debian/copyright DESTINATION ${GUIDEWAY_DOC_DIR})

# Man pages and the changelog, compressed as Debian wants them (gzip -9n: no name, no time stamp).
find_program(GZIP gzip REQUIRED)
set(compressed)
foreach(page guideway.1 guideway-emulate.1 guideway-linuxcnc-bridge.1 guidewayd.8 changelog)
  if(page STREQUAL "changelog")
    set(src ${PROJECT_SOURCE_DIR}/packaging/debian/changelog)
  else()
    set(src ${PROJECT_SOURCE_DIR}/packaging/man/${page})
  endif()
  set(out ${PROJECT_BINARY_DIR}/packaging/${page}.gz)
  add_custom_command(OUTPUT ${out} COMMAND ${CMAKE_COMMAND} -E make_directory ${PROJECT_BINARY_DIR}/packaging
                     COMMAND ${GZIP} -9n -c ${src} > ${out} DEPENDS ${src} VERBATIM)
  list(APPEND compressed ${out})
  if(page STREQUAL "changelog")
    install(FILES ${out} DESTINATION ${GUIDEWAY_DOC_DIR})
  else()
    string(REGEX REPLACE ".*\\.([0-9])$" "\\1" section ${page})
    install(FILES ${out} DESTINATION ${CMAKE_INSTALL_MANDIR}/man${section})
  endif()
endforeach()
add_custom_target(guideway_package_files ALL DEPENDS ${compressed})

set(CPACK_GENERATOR DEB)
set(CPACK_PACKAGE_NAME guideway)
set(CPACK_PACKAGE_VENDOR "Guideway developers")
set(CPACK_PACKAGE_CONTACT "Guideway developers <guideway@example.com>")
set(CPACK_PACKAGE_DESCRIPTION_SUMMARY "real-time metrology acquisition daemon for machine tools")
# The long description: lines of at most 80 characters, an empty line between paragraphs (CPack indents them
# and writes the empty one as " .").
set(CPACK_DEBIAN_PACKAGE_DESCRIPTION
    "Guideway runs beside the CNC on a machine tool's controller PC: it acquires a
double ball bar and axis encoders on CAN, an autocollimator, an inductance
micrometer and a profilometer, identifies the machine's geometric errors,
explains what its models leave out, and writes compensation tables a
controller loads.

With LinuxCNC it closes the loop: guideway-linuxcnc-bridge serves every servo
period to guidewayd, guideway program dbb writes the ballbar test's G-code,
guideway linuxcnc offsets writes the squareness and straightness as LinuxCNC's
external offsets, and linuxcnc_demo.sh in /usr/share/guideway/linuxcnc runs
the loop headless on a simulated machine.")
set(CPACK_DEBIAN_PACKAGE_SECTION science)
set(CPACK_DEBIAN_PACKAGE_PRIORITY optional)
set(CPACK_DEBIAN_FILE_NAME DEB-DEFAULT)
set(CPACK_DEBIAN_PACKAGE_SHLIBDEPS ON)
set(CPACK_DEBIAN_PACKAGE_DEPENDS "python3, systemd")
set(CPACK_DEBIAN_PACKAGE_SUGGESTS "linuxcnc-uspace")
set(CPACK_DEBIAN_PACKAGE_CONTROL_EXTRA ${PROJECT_SOURCE_DIR}/packaging/debian/postinst
    ${PROJECT_SOURCE_DIR}/packaging/debian/prerm ${PROJECT_SOURCE_DIR}/packaging/debian/postrm
    ${PROJECT_SOURCE_DIR}/packaging/debian/conffiles)
set(CPACK_DEBIAN_PACKAGE_CONTROL_STRICT_PERMISSION TRUE)
set(CPACK_STRIP_FILES TRUE)
set(CPACK_SET_DESTDIR ON)
set(CPACK_INSTALL_PREFIX /usr)
set(CPACK_DEBIAN_COMPRESSION_TYPE xz)
include(CPack)
