# Command-line checks of the case reader and --set: overlaps, materials, periodic axes, paths.
include(${CMAKE_CURRENT_LIST_DIR}/cli_common.cmake)
file(REMOVE_RECURSE ${WORK})
file(MAKE_DIRECTORY ${WORK})
