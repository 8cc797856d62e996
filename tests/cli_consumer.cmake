# Installs bondem into a scratch prefix and builds and runs tests/consumer against it: another
# CMake project finds the package and links bondem::engine.
file(REMOVE_RECURSE ${WORK})
execute_process(COMMAND ${CMAKE_COMMAND} --install ${BUILD} --prefix ${WORK}/prefix
                RESULT_VARIABLE status OUTPUT_QUIET ERROR_VARIABLE err)
if(NOT status EQUAL 0)
  message(FATAL_ERROR "cmake --install failed: ${err}")
endif()
foreach(step configure build run)
  if(step STREQUAL configure)
    set(command ${CMAKE_COMMAND} -S ${SOURCE}/tests/consumer -B ${WORK}/build
                -DCMAKE_PREFIX_PATH=${WORK}/prefix -DCMAKE_BUILD_TYPE=Release)
  elseif(step STREQUAL build)
    set(command ${CMAKE_COMMAND} --build ${WORK}/build)
  else()
    set(command ${WORK}/build/consumer)
  endif()
  execute_process(COMMAND ${command} RESULT_VARIABLE status OUTPUT_VARIABLE out
                  ERROR_VARIABLE err)
  if(NOT status EQUAL 0)
    message(FATAL_ERROR "consumer ${step} failed (${status}): ${out} ${err}")
  endif()
endforeach()
message(STATUS "consumer: ${out}")
