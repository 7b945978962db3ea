# Install layout (`cmake --install build/default [--prefix P]`, default prefix /usr/local):
#   P/bin/netkf                         -> ../libexec/netkf/cli/netkf (symlink)
#   P/libexec/netkf/cli/netkf           the CLI
#   P/libexec/netkf/plant_node, sensor_node, channel_emulator, estimator_node
#   P/share/netkf/scenarios/*.yaml      deploy/scenarios
#   P/share/netkf/dds/*.xml             deploy/dds (Fast DDS and Cyclone DDS profiles)
#   P/share/netkf/systemd/*.env         example environment files (deploy/systemd)
#   P/lib/systemd/system/netkf@.service the unit template, its ExecStart pointing at P/bin/netkf
#   P/lib/sysusers.d/netkf.conf         the service's system user (systemd-sysusers)
# The CLI finds its node executables from its own resolved path (cli/launch/launch_supervisor.cpp,
# node_binary_root: the directory above the CLI's, then <root>/<node>), so the real CLI sits
# one directory below the nodes, as in the build tree; the symlink in bin/ resolves to it.
include(GNUInstallDirs)
set(NETKF_INSTALL_LIBEXEC ${CMAKE_INSTALL_LIBEXECDIR}/netkf)
set(NETKF_INSTALL_DATA ${CMAKE_INSTALL_DATADIR}/netkf)

install(TARGETS plant_node sensor_node channel_emulator estimator_node
  RUNTIME DESTINATION ${NETKF_INSTALL_LIBEXEC})
install(TARGETS netkf RUNTIME DESTINATION ${NETKF_INSTALL_LIBEXEC}/cli)
file(RELATIVE_PATH netkf_link_target ${CMAKE_INSTALL_PREFIX}/${CMAKE_INSTALL_BINDIR}
     ${CMAKE_INSTALL_PREFIX}/${NETKF_INSTALL_LIBEXEC}/cli/netkf)
install(CODE "
  set(link \"\$ENV{DESTDIR}\${CMAKE_INSTALL_PREFIX}/${CMAKE_INSTALL_BINDIR}/netkf\")
  file(MAKE_DIRECTORY \"\$ENV{DESTDIR}\${CMAKE_INSTALL_PREFIX}/${CMAKE_INSTALL_BINDIR}\")
  message(STATUS \"Installing: \${link} -> ${netkf_link_target}\")
  file(CREATE_LINK \"${netkf_link_target}\" \"\${link}\" SYMBOLIC)")

install(DIRECTORY ${PROJECT_SOURCE_DIR}/deploy/scenarios/ DESTINATION ${NETKF_INSTALL_DATA}/scenarios
  FILES_MATCHING PATTERN "*.yaml")
install(FILES
  ${PROJECT_SOURCE_DIR}/deploy/dds/localhost.xml
  ${PROJECT_SOURCE_DIR}/deploy/dds/discovery-server.xml
  ${PROJECT_SOURCE_DIR}/deploy/dds/cyclonedds-localhost.xml
  DESTINATION ${NETKF_INSTALL_DATA}/dds)
install(FILES
  ${PROJECT_SOURCE_DIR}/deploy/systemd/host-a.env
  ${PROJECT_SOURCE_DIR}/deploy/systemd/host-b.env
  ${PROJECT_SOURCE_DIR}/deploy/systemd/host-c.env
  DESTINATION ${NETKF_INSTALL_DATA}/systemd)

# The unit as shipped runs /usr/local/bin/netkf (the default prefix); installed under another
# prefix (--prefix at install time too), it runs that prefix's CLI.
install(CODE "
  file(READ \"${PROJECT_SOURCE_DIR}/deploy/systemd/netkf@.service\" unit)
  string(REPLACE \"/usr/local/bin/netkf\" \"\${CMAKE_INSTALL_PREFIX}/${CMAKE_INSTALL_BINDIR}/netkf\" unit \"\${unit}\")
  set(dest \"\$ENV{DESTDIR}\${CMAKE_INSTALL_PREFIX}/lib/systemd/system/netkf@.service\")
  message(STATUS \"Installing: \${dest}\")
  file(WRITE \"\${dest}\" \"\${unit}\")")
install(FILES ${PROJECT_SOURCE_DIR}/deploy/systemd/netkf.sysusers.conf DESTINATION lib/sysusers.d RENAME netkf.conf)
