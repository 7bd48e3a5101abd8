# Where tsf's bundled files live, installed and in a build tree.
#
# Installed (cmake --install BUILD --prefix PREFIX):
#   PREFIX/bin/tsf
#   PREFIX/share/tsf/{scenes,materials,data-samples,presets/segment}   found relative to the
#   PREFIX/share/doc/tsf/                                              executable (bin/../share/tsf)
# A build tree gets the same shape: BUILD/share/tsf/* are links to the source folders, so the tsf
# in BUILD/bin and the test and bench programs in BUILD/* find them the same way, and no source
# path is compiled into any binary (app/run/repo_paths.cpp, segment_preset_dirs()).
set(TSF_DATA_SUBDIR ${CMAKE_INSTALL_DATADIR}/tsf)
file(MAKE_DIRECTORY ${CMAKE_BINARY_DIR}/share/tsf/presets)
foreach(_pair "scenes;scenes" "materials;materials" "data-samples;data-samples"
              "segment/presets;presets/segment")
  list(GET _pair 0 _from)
  list(GET _pair 1 _to)
  if(NOT EXISTS ${CMAKE_BINARY_DIR}/share/tsf/${_to})
    file(CREATE_LINK ${CMAKE_SOURCE_DIR}/${_from} ${CMAKE_BINARY_DIR}/share/tsf/${_to} SYMBOLIC)
  endif()
endforeach()

install(DIRECTORY ${CMAKE_SOURCE_DIR}/scenes/ DESTINATION ${TSF_DATA_SUBDIR}/scenes)
install(DIRECTORY ${CMAKE_SOURCE_DIR}/materials/ DESTINATION ${TSF_DATA_SUBDIR}/materials)
install(DIRECTORY ${CMAKE_SOURCE_DIR}/data-samples/ DESTINATION ${TSF_DATA_SUBDIR}/data-samples)
install(DIRECTORY ${CMAKE_SOURCE_DIR}/docs/ DESTINATION ${CMAKE_INSTALL_DOCDIR})
install(FILES ${CMAKE_SOURCE_DIR}/README.md DESTINATION ${CMAKE_INSTALL_DOCDIR})

# A Debian package of the installed tree (cpack -G DEB in the build folder): its dependencies are
# Debian's shared-library packages by name, found by dpkg-shlibdeps from what tsf links.
set(CPACK_GENERATOR "DEB")
set(CPACK_PACKAGE_NAME "tsf")
set(CPACK_PACKAGE_VERSION ${PROJECT_VERSION})
set(CPACK_PACKAGE_DESCRIPTION_SUMMARY "CT scan to an interactive, cuttable soft-tissue asset")
set(CPACK_PACKAGE_CONTACT "tsf developers <tsf@localhost>")
set(CPACK_PACKAGING_INSTALL_PREFIX "/usr")
set(CPACK_DEBIAN_FILE_NAME DEB-DEFAULT)
set(CPACK_DEBIAN_PACKAGE_SHLIBDEPS ON)
set(CPACK_DEBIAN_PACKAGE_SECTION "science")
set(CPACK_STRIP_FILES ON)
include(CPack)
