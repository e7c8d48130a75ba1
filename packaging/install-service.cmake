# Installs the service's configuration and systemd unit (included by cmake_install.cmake; see the
# install section of CMakeLists.txt, which sets CANDP2_SOURCE_DIR, CANDP2_BINARY_DIR and
# CANDP2_BINDIR). Decided at install time, so that `cmake --install --prefix P` is honoured:
#   prefix /usr:  /etc/candp2/candp2d.json, /lib/systemd/system/candp2d.service and
#                 candp2d@.service (Debian 12's layout, as GNUInstallDirs puts sysconfdir for /usr)
#   prefix P:     P/etc/candp2/candp2d.json, P/lib/systemd/system/candp2d.service, the unit's
#                 ExecStart naming P/bin/candp2d and P/etc/candp2/candp2d.json
# file(INSTALL) adds DESTDIR itself.
if(CMAKE_INSTALL_PREFIX STREQUAL "/usr")
  set(_etc /etc)
  set(_units /lib/systemd/system)
else()
  set(_etc "${CMAKE_INSTALL_PREFIX}/etc")
  set(_units "${CMAKE_INSTALL_PREFIX}/lib/systemd/system")
endif()
file(INSTALL DESTINATION "${_etc}/candp2" TYPE FILE
     FILES "${CANDP2_BINARY_DIR}/packaging/candp2d.json")

# The unit and the template of one instance per line (candp2d@NAME runs /etc/candp2/NAME.json),
# their ExecStart adjusted to the prefix.
foreach(_name candp2d.service candp2d@.service)
  file(READ "${CANDP2_SOURCE_DIR}/packaging/systemd/${_name}" _unit)
  string(REGEX REPLACE "ExecStart=/usr/bin/candp2d --config /etc/candp2/"
                       "ExecStart=${CMAKE_INSTALL_PREFIX}/${CANDP2_BINDIR}/candp2d --config ${_etc}/candp2/"
                       _unit "${_unit}")
  file(WRITE "${CANDP2_BINARY_DIR}/packaging/install/${_name}" "${_unit}")
  file(INSTALL DESTINATION "${_units}" TYPE FILE
       FILES "${CANDP2_BINARY_DIR}/packaging/install/${_name}")
endforeach()
