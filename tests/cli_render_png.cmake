# scripts/render-png.py draws a frame of a run to a PNG of the size asked for, and refuses an
# array the frame does not have, listing those it has. Skipped (SKIP_REGULAR_EXPRESSION) where
# Debian's python3-vtk9 or xvfb-run is missing: scripts/install-deps.sh installs both.
include(${CMAKE_CURRENT_LIST_DIR}/cli_common.cmake)
file(REMOVE_RECURSE ${WORK})
file(MAKE_DIRECTORY ${WORK})

execute_process(COMMAND /usr/bin/python3 -c "import vtkmodules" RESULT_VARIABLE no_vtk
                OUTPUT_QUIET ERROR_QUIET)
find_program(xvfb_run xvfb-run)
if(no_vtk OR NOT xvfb_run)
  message("RENDER_PNG_SKIPPED: no python3-vtk9 under /usr/bin/python3 or no xvfb-run")
  return()
endif()

# 2 ms of the pouring case: about 100 spheres streamed in, frames at 0, 1 and 2 ms.
expect_success(run ${CASES}/powder_pouring_ci.yaml --quiet --output ${WORK}/run
               --set time.end=0.002 --set output.vtk_interval=0.001)
set(render ${SCRIPTS}/render-png.py)
execute_process(COMMAND ${render} ${WORK}/run --view side --color-by velocity:z --size 320 200
                        -o ${WORK}/frame.png
                RESULT_VARIABLE status OUTPUT_VARIABLE out ERROR_VARIABLE err)
if(NOT status EQUAL 0)
  message(FATAL_ERROR "render-png.py failed (${status}): ${out} ${err}")
endif()
expect_text("${out}" "particles, velocity z" "render-png.py's report")
# A PNG: the signature, then the IHDR chunk with the width and height (big-endian) at byte 16.
file(READ ${WORK}/frame.png header LIMIT 24 HEX)
string(SUBSTRING "${header}" 0 16 signature)
string(SUBSTRING "${header}" 32 16 size)
if(NOT signature STREQUAL "89504e470d0a1a0a" OR NOT size STREQUAL "00000140000000c8")
  message(FATAL_ERROR "frame.png is not a 320 x 200 PNG: ${header}")
endif()
file(SIZE ${WORK}/frame.png bytes)
if(bytes LESS 2000)  # a blank 320 x 200 picture compresses to a few hundred bytes
  message(FATAL_ERROR "frame.png holds ${bytes} bytes: nothing drawn?")
endif()

execute_process(COMMAND ${render} ${WORK}/run --color-by pressure -o ${WORK}/bad.png
                RESULT_VARIABLE status OUTPUT_VARIABLE out ERROR_VARIABLE err)
if(status EQUAL 0 OR EXISTS ${WORK}/bad.png)
  message(FATAL_ERROR "render-png.py drew an array the frame lacks")
endif()
expect_text("${err}" "has no point array 'pressure'; it has: id, radius" "the refusal")
