# Shared by the command-line tests: run bondem and check the contract for bad input.

# Runs bondem with ARGN: it must exit with status 2 and print one line containing expected_text.
function(expect_bad_input expected_text)
  execute_process(COMMAND ${BONDEM} ${ARGN} RESULT_VARIABLE status ERROR_VARIABLE err
                  OUTPUT_VARIABLE out)
  if(NOT status EQUAL 2)
    message(FATAL_ERROR "expected exit 2 from '${ARGN}', got ${status}: ${err}")
  endif()
  string(FIND "${err}" "${expected_text}" found)
  if(found EQUAL -1)
    message(FATAL_ERROR "'${ARGN}': stderr lacks '${expected_text}': ${err}")
  endif()
  string(STRIP "${err}" stripped)
  string(FIND "${stripped}" "\n" newline)
  if(NOT newline EQUAL -1)
    message(FATAL_ERROR "'${ARGN}': expected a one-line reason, got: ${err}")
  endif()
endfunction()

# Runs bondem with ARGN: it must exit 0; its stdout and stderr go to `out` and `err`.
function(expect_success)
  execute_process(COMMAND ${BONDEM} ${ARGN} RESULT_VARIABLE status ERROR_VARIABLE err_text
                  OUTPUT_VARIABLE out_text)
  if(NOT status EQUAL 0)
    message(FATAL_ERROR "expected exit 0 from '${ARGN}', got ${status}: ${err_text}")
  endif()
  set(out "${out_text}" PARENT_SCOPE)
  set(err "${err_text}" PARENT_SCOPE)
endfunction()

# Fails unless `text` contains `expected`.
function(expect_text text expected what)
  string(FIND "${text}" "${expected}" found)
  if(found EQUAL -1)
    message(FATAL_ERROR "${what}: expected '${expected}' in: ${text}")
  endif()
endfunction()
