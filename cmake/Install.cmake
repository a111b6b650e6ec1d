# `cmake --install build --prefix P` and the .deb (cpack -G DEB in the build folder). Layout, read
# relative to the executable by facecast/core/install.hpp:
#   P/bin/facecast
#   P/share/facecast/configs/              (every config; the server's defaults in server.json)
#   P/share/facecast/web/                  (the web client)
#   P/share/facecast/clients/js/           (the JS client, served at /vendor/facecast/ for the web client)
#   P/share/facecast/node_modules/three/   (build/ and examples/jsm/: the client's import map)
#   P/share/facecast/node_modules/@pixiv/three-vrm/lib/
#   P/share/facecast/zh_lexicon.txt        (the Chinese lexicon compiled at build time)
#   P/share/facecast/ict_facekit.glb       (the shipped template, rigbuild/data/ in the source tree)
#   P/share/facecast/deploy/               (systemd unit, nginx configs)
include(GNUInstallDirs)
set(FACECAST_SHARE ${CMAKE_INSTALL_DATADIR}/facecast)
set(FACECAST_NODE ${CMAKE_CURRENT_SOURCE_DIR}/node_modules)

install(TARGETS facecast RUNTIME DESTINATION ${CMAKE_INSTALL_BINDIR})
install(DIRECTORY configs/ DESTINATION ${FACECAST_SHARE}/configs)
install(DIRECTORY web/ DESTINATION ${FACECAST_SHARE}/web)
install(DIRECTORY clients/js/ DESTINATION ${FACECAST_SHARE}/clients/js PATTERN "node_modules" EXCLUDE PATTERN "tests" EXCLUDE)
install(DIRECTORY ${FACECAST_NODE}/three/build ${FACECAST_NODE}/three/examples
        DESTINATION ${FACECAST_SHARE}/node_modules/three PATTERN "*.d.ts" EXCLUDE)
install(FILES ${FACECAST_NODE}/three/LICENSE ${FACECAST_NODE}/three/package.json
        DESTINATION ${FACECAST_SHARE}/node_modules/three)
install(DIRECTORY ${FACECAST_NODE}/@pixiv/three-vrm/lib
        DESTINATION ${FACECAST_SHARE}/node_modules/@pixiv/three-vrm)
install(FILES ${FACECAST_NODE}/@pixiv/three-vrm/LICENSE
        DESTINATION ${FACECAST_SHARE}/node_modules/@pixiv/three-vrm)
install(FILES ${CMAKE_BINARY_DIR}/viseme/zh_lexicon.txt DESTINATION ${FACECAST_SHARE})
install(FILES ${FACECAST_SHIPPED_TEMPLATE} rigbuild/data/ict_facekit.LICENSE DESTINATION ${FACECAST_SHARE})
install(FILES deploy/facecast.service deploy/nginx.conf deploy/nginx-rtmp.conf deploy/server.json
        DESTINATION ${FACECAST_SHARE}/deploy)

# The .deb: installs under /usr; the unit goes where systemd looks for packaged units.
set(CPACK_PACKAGE_NAME facecast)
set(CPACK_PACKAGE_VENDOR "Facecast")
set(CPACK_PACKAGE_CONTACT "Facecast maintainers <facecast@localhost>")
set(CPACK_PACKAGE_DESCRIPTION_SUMMARY "Speech-driven avatar animation server")
set(CPACK_PACKAGING_INSTALL_PREFIX /usr)
set(CPACK_GENERATOR DEB)
set(CPACK_DEBIAN_FILE_NAME DEB-DEFAULT)
set(CPACK_DEBIAN_PACKAGE_SECTION net)
# Shared libraries from dpkg-shlibdeps; data packages the binary reads at run time by hand.
set(CPACK_DEBIAN_PACKAGE_SHLIBDEPS ON)
set(CPACK_DEBIAN_PACKAGE_DEPENDS "espeak-ng-data, libdlib-data, ffmpeg, libegl-mesa0, libgl1-mesa-dri")
set(CPACK_DEBIAN_PACKAGE_SUGGESTS "nginx, redis-server")
install(FILES deploy/facecast.service DESTINATION lib/systemd/system)
include(CPack)
