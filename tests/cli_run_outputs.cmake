# Command-line checks of the run loop: step counts, restarts, the output directory, resume hints.
include(${CMAKE_CURRENT_LIST_DIR}/cli_common.cmake)
file(REMOVE_RECURSE ${WORK})
file(MAKE_DIRECTORY ${WORK})
set(paper ${CASES}/paper_5_1.yaml)

# Issue 12, item 3: step counts that overflowed (`steps = -9223372036854775808`, exit 0) are
# refused, naming the key that was set and the limit.
expect_bad_input("--set time.end=1e13: 'time.end': gives 2e+19 steps" run ${paper} --quiet
                 --output ${WORK}/steps --set time.end=1e13)
expect_bad_input("--set time.step=1e-300: 'time.step'" run ${paper} --quiet
                 --output ${WORK}/steps --set time.step=1e-300)
expect_bad_input("limit of 1e+12 steps" run ${paper} --quiet --output ${WORK}/steps
                 --set time.end=1e13)

# Item 2: a restart whose end is not after the checkpoint printed `steps = -95000` and exit 0.
expect_success(run ${paper} --quiet --output ${WORK}/first --set time.end=0.002)
expect_bad_input("'time.end': 0.001 s is not after the time of the checkpoint" run ${paper}
                 --quiet --output ${WORK}/first --set time.end=0.001
                 --restart ${WORK}/first/checkpoint.bin)
expect_bad_input(", 0.002 s: raise time.end" run ${paper} --quiet --output ${WORK}/first
                 --set time.end=0.002 --restart ${WORK}/first/checkpoint.bin)

# Item 10: a directory given as the checkpoint gave "failed: std::bad_alloc".
expect_bad_input("${WORK}/first: not a checkpoint file" run ${paper} --quiet
                 --output ${WORK}/second --restart ${WORK}/first)

# Item 9: an output directory that cannot be written is refused before step 0 (a file stands
# where a parent directory should be: refused even for root, which ignores permissions).
file(WRITE ${WORK}/a_file "not a directory\n")
expect_bad_input("--output ${WORK}/a_file/out: cannot write the output directory" run ${paper}
                 --quiet --output ${WORK}/a_file/out)
expect_bad_input("'output.directory': cannot write the output directory ${WORK}/a_file/out"
                 run ${paper} --quiet --set output.directory=${WORK}/a_file/out)

# Item 18: SIGINT prints the exact command that resumes the run, --set options, --threads and
# shell quoting included. The run is long (1e8 steps); SIGINT is sent once history.csv has its
# first row, written live after the signal handlers are installed.
set(spaced "${WORK}/resume here")
execute_process(
  COMMAND sh -c "\"$0\" run \"$1\" --quiet --threads 1 --output \"$2\" --set time.end=50 & \
pid=$!; i=0; \
while [ ! -s \"$2/history.csv\" ] && [ $i -lt 600 ]; do sleep 0.05; i=$((i+1)); done; \
kill -INT $pid; wait $pid"
          ${BONDEM} ${paper} ${spaced}
  RESULT_VARIABLE status ERROR_VARIABLE err OUTPUT_VARIABLE out)
if(NOT status EQUAL 130)
  message(FATAL_ERROR "expected exit 130 after SIGINT, got ${status}: ${err}")
endif()
set(expected "Resume with: ${BONDEM} run ${paper} --quiet --threads 1 --output '${spaced}' \
--set time.end=50 --restart '${spaced}/checkpoint.bin'")
string(FIND "${err}" "${expected}" found)
if(found EQUAL -1)
  message(FATAL_ERROR "the resume hint is not the command line:\n${err}\nexpected:\n${expected}")
endif()

# Items 4 and 17: a history value that is not finite (the mean of temperatures near the largest
# double overflows) stops the run as a blow-up, exit 3, without writing the row; the final state
# and checkpoint of an earlier run in the same directory do not stay beside its history.
set(blown ${WORK}/blown)
expect_success(run ${paper} --quiet --output ${blown})
execute_process(COMMAND ${BONDEM} run ${CASES}/laser_sintering_ci.yaml --quiet --output ${blown}
                        --set time.end=3e-7 --set thermal.initial_temperature=1e308
                RESULT_VARIABLE status ERROR_VARIABLE err OUTPUT_VARIABLE out)
if(NOT status EQUAL 3)
  message(FATAL_ERROR "expected a blow-up (exit 3), got ${status}: ${err}")
endif()
file(READ ${blown}/history.csv history)
if(history MATCHES "inf|nan")
  message(FATAL_ERROR "history.csv holds a non-finite value:\n${history}")
endif()
foreach(stale final_state.csv checkpoint.bin clusters.csv)
  if(EXISTS ${blown}/${stale})
    message(FATAL_ERROR "${stale} of the earlier run stayed beside the blown-up run's history")
  endif()
endforeach()
if(NOT EXISTS ${blown}/last_good_state.csv)
  message(FATAL_ERROR "the blow-up wrote no last_good_state.csv: ${err}")
endif()
