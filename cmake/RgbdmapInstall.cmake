# `cmake --install build` and the Debian package (bash deploy/package.sh -> build/rgbdmap_<version>_<arch>.deb).
# Debian layout with the prefix /usr (the default here): programs in /usr/bin, configuration in /etc/rgbdmap
# (conffiles), the DDS configurations in /usr/share/rgbdmap/dds, documentation in /usr/share/doc/rgbdmap,
# systemd units in /usr/lib/systemd/system. Libraries are static and linked into the programs; tests and
# benchmarks are not installed.
set(RGBDMAP_INSTALL_FULL_CONFDIR "${CMAKE_INSTALL_FULL_SYSCONFDIR}/rgbdmap")
set(RGBDMAP_INSTALL_SYSTEMD_DIR "${CMAKE_INSTALL_PREFIX}/lib/systemd/system")
set(RGBDMAP_INSTALL_SYSUSERS_DIR "${CMAKE_INSTALL_PREFIX}/lib/sysusers.d")

install(TARGETS rgbdmap rgbdmap-client rgbdmap-server rgbdmap-monitor rgbdmap-viewer rgbdmap-ros2 RUNTIME DESTINATION ${CMAKE_INSTALL_BINDIR})

# Configuration: the documented defaults, an example DDS configuration for a robot network (to be edited),
# the services' environment files (client.env: copy to client-<robot>.env per robot).
set(_deploy ${PROJECT_SOURCE_DIR}/deploy)
set(_generated ${PROJECT_BINARY_DIR}/deploy)
foreach(unit rgbdmap-server.service rgbdmap-client@.service rgbdmap-server.env rgbdmap-client.env)
  configure_file(${_deploy}/systemd/${unit}.in ${_generated}/systemd/${unit} @ONLY)
endforeach()
set(RGBDMAP_CONFFILES server.yaml client.yaml odometry.yaml cyclonedds.xml server.env client.env)
install(FILES ${_deploy}/config/server.yaml ${_deploy}/config/client.yaml ${_deploy}/config/odometry.yaml
        DESTINATION ${RGBDMAP_INSTALL_FULL_CONFDIR})
install(FILES ${_deploy}/dds/cyclonedds-robot-network.xml DESTINATION ${RGBDMAP_INSTALL_FULL_CONFDIR}
        RENAME cyclonedds.xml)
install(FILES ${_generated}/systemd/rgbdmap-server.env DESTINATION ${RGBDMAP_INSTALL_FULL_CONFDIR} RENAME server.env)
install(FILES ${_generated}/systemd/rgbdmap-client.env DESTINATION ${RGBDMAP_INSTALL_FULL_CONFDIR} RENAME client.env)
install(FILES ${_deploy}/dds/cyclonedds-loopback.xml ${_deploy}/dds/cyclonedds-robot-network.xml
        DESTINATION ${CMAKE_INSTALL_DATADIR}/rgbdmap/dds)
install(FILES ${_generated}/systemd/rgbdmap-server.service ${_generated}/systemd/rgbdmap-client@.service
        DESTINATION ${RGBDMAP_INSTALL_SYSTEMD_DIR})
install(FILES ${_deploy}/package/rgbdmap.sysusers DESTINATION ${RGBDMAP_INSTALL_SYSUSERS_DIR} RENAME rgbdmap.conf)
install(FILES ${PROJECT_SOURCE_DIR}/apps/viewer/web/index.html ${PROJECT_SOURCE_DIR}/apps/viewer/web/viewer.js
        DESTINATION ${RGBDMAP_INSTALL_FULL_DATADIR}/viewer)
install(FILES ${PROJECT_SOURCE_DIR}/README.md ${_deploy}/lcm.md DESTINATION ${CMAKE_INSTALL_DOCDIR})
install(FILES ${PROJECT_SOURCE_DIR}/proto/README.md DESTINATION ${CMAKE_INSTALL_DOCDIR} RENAME protocol.md)
install(DIRECTORY ${PROJECT_SOURCE_DIR}/docs/ DESTINATION ${CMAKE_INSTALL_DOCDIR}/docs)

# The .deb: runtime library dependencies derived by dpkg-shlibdeps (dpkg-dev); /etc files are conffiles
# (kept when edited); postinst creates the system user rgbdmap.
set(RGBDMAP_PACKAGE_MAINTAINER "rgbdmap maintainers <maintainers@users.noreply.h-seed-7341eb49.example>"
    CACHE STRING "Maintainer field of the Debian package")
set(_conffiles "")
foreach(f ${RGBDMAP_CONFFILES})
  string(APPEND _conffiles "${RGBDMAP_INSTALL_FULL_CONFDIR}/${f}\n")
endforeach()
file(WRITE ${_generated}/package/conffiles "${_conffiles}")
configure_file(${_deploy}/package/postinst ${_generated}/package/postinst @ONLY
               FILE_PERMISSIONS OWNER_READ OWNER_WRITE OWNER_EXECUTE GROUP_READ GROUP_EXECUTE WORLD_READ WORLD_EXECUTE)

set(CPACK_GENERATOR DEB)
set(CPACK_PACKAGE_NAME rgbdmap)
set(CPACK_PACKAGE_VERSION ${PROJECT_VERSION})
set(CPACK_PACKAGE_CONTACT "${RGBDMAP_PACKAGE_MAINTAINER}")
set(CPACK_PACKAGE_DESCRIPTION_SUMMARY "multi-robot RGB-D mapping service")
# The long description (CPack puts the summary above it).
set(CPACK_DEBIAN_PACKAGE_DESCRIPTION "rgbdmap-server merges the keyframes of many robots into one pose graph and
occupancy map (loop closure, map merging, pose corrections back to the robots); rgbdmap-client runs visual
odometry on a robot and talks to the server over LCM or Cyclone DDS; rgbdmap-monitor shows the server's
status; rgbdmap runs a whole deployment in one process and evaluates trajectories. Includes systemd units.")
set(CPACK_DEBIAN_PACKAGE_MAINTAINER "${RGBDMAP_PACKAGE_MAINTAINER}")
set(CPACK_DEBIAN_PACKAGE_SECTION science)
set(CPACK_DEBIAN_FILE_NAME DEB-DEFAULT)  # rgbdmap_<version>_<arch>.deb
set(CPACK_DEBIAN_PACKAGE_SHLIBDEPS ON)
set(CPACK_DEBIAN_PACKAGE_CONTROL_EXTRA "${_generated}/package/postinst;${_generated}/package/conffiles")
set(CPACK_DEBIAN_PACKAGE_CONTROL_STRICT_PERMISSION TRUE)
set(CPACK_PACKAGING_INSTALL_PREFIX "${CMAKE_INSTALL_PREFIX}")
set(CPACK_PACKAGE_DIRECTORY "${PROJECT_BINARY_DIR}")
set(CPACK_STRIP_FILES ON)
include(CPack)
