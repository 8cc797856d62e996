# `mpirun -np PROCESSES bondem run` against the run in one process: the same bytes.
# With PROCESSES 0 it writes the references (the run in one process, the fixture of the others).
# Each case is run into WORK/<case>_<processes>; every output is compared with the reference's,
# and so is the run's printed summary (summary.txt: the end-of-run figures, less the timings):
#   pour       tests/cases/storage_order.yaml: 1 100 frictional spheres thrown at a floor across
#              periodic x and y, pushed by a moving blade, every contact bonding; a checkpoint
#              midway, VTK frames every 0.6 ms (on PROCESSES processes, one piece a process; they
#              must show what the reference's whole frames show: FRAMES_MATCH). Then the same run
#              stopped midway on PROCESSES processes and continued from its checkpoint on another
#              number of processes, its frames continued in as many pieces.
#   spreading  cases/powder_spreading_ci.yaml without its VTK frames, shortened to 3 ms with the
#              blade moving from 0.5 ms at 0.4 m/s, through the falling heap (layer.csv included),
#              with state snapshots every ms and a layer series at 1 and 2 ms.
#   thermal    tests/cases/thermal_bonding.yaml: heat flow, temperature-criterion bonds, the
#              substrate's load.
#   migration  tests/cases/migration_stress.yaml: crossing streams in a box periodic along x, y
#              and z; every sphere crosses the cuts and the periodic faces.
#   leaving    the migration stress test with z not periodic and domain.remove_outside: 139 of
#              the 500 spheres leave through the z faces and are removed (counted, with their
#              mass, in history.csv).
#   laser      cases/laser_sintering_ci.yaml with its beam on from 50 us to the end at 100 us,
#              over the falling powder: the processes agree on the beam's columns (each column's
#              highest particle over all of them), so each particle absorbs what it absorbs in one
#              process; VTK frames compared as the pour's.
#   stream     cases/powder_pouring_ci.yaml, shortened to 10 ms: a stream pours 500 spheres into
#              an empty box, each process inserting alike from the particles near the stream's
#              region gathered from all (history.csv counts them); VTK frames every 5 ms, compared
#              as the pour's. Then stopped at 5 ms and continued from its checkpoint on another
#              number.
#   stage      the pour's second stage: its box from the reference pour's end (initial_state:
#              its checkpoint, bonds and springs included), 2 ms more; each process builds only
#              its own particles of the state, whose pairs' state the parts take by ids.
#   drum       cases/rotating_drum_ci.yaml, shortened to 40 ms: spheres falling into a rotating
#              drum that is a triangle mesh (every process holds the whole mesh; 159 spheres touch
#              it at the end, their contact history travelling with them); VTK frames at 0 and
#              40 ms, compared as the pour's.
include(${CMAKE_CURRENT_LIST_DIR}/cli_common.cmake)

file(MAKE_DIRECTORY ${WORK})
file(READ ${CASES}/powder_spreading_ci.yaml spreading)
string(REGEX REPLACE "\n *vtk_interval:[^\n]*" "" spreading "${spreading}")
# A layer series besides the end's layer: measured at 1 and 2 ms, through the falling heap.
string(REPLACE "analysis:\n" "analysis:\n  layers: {times: [0.001, 0.002], x_min: 0.0016, \
x_max: 0.0024, y_min: 0.0, y_max: 0.0005, substrate_z: 0.0, layer_height: 0.00025, bins: 4}\n"
       spreading "${spreading}")
file(WRITE ${WORK}/spreading.yaml "${spreading}")

file(READ ${TEST_CASES}/storage_order.yaml stage)
# One spelling of the path for every process count: the case's fingerprint (in its checkpoint)
# includes it.
get_filename_component(stage_state ${WORK}/../cli_mpi_run_0_work/pour_0/checkpoint.bin ABSOLUTE)
string(REGEX REPLACE "\ninsert:\n.*\ntime:" "
initial_state: {file: ${stage_state}}
time:" stage "${stage}")
file(WRITE ${WORK}/stage.yaml "${stage}")

set(pour_case ${TEST_CASES}/storage_order.yaml)
set(pour_options --set time.end=0.0024 --set output.checkpoint_interval=0.0012
                 --set output.history_interval=0.0002 --set output.vtk_interval=0.0006)
set(spreading_case ${WORK}/spreading.yaml)
set(spreading_options --set walls.2.motion.1.time=0.0005 --set walls.2.motion.1.velocity.0=0.4
                      --set time.end=0.003 --set output.history_interval=0.0002
                      --set output.state_interval=0.001)
set(thermal_case ${TEST_CASES}/thermal_bonding.yaml)
set(thermal_options)
set(migration_case ${TEST_CASES}/migration_stress.yaml)
set(migration_options)
set(leaving_case ${TEST_CASES}/migration_stress.yaml)
set(leaving_options --set domain.periodic.2=false --set domain.remove_outside=true)
set(laser_case ${CASES}/laser_sintering_ci.yaml)
set(laser_options --set laser.start_time=0.00005 --set time.end=0.0001
                  --set output.vtk_interval=0.00005 --set output.checkpoint_interval=0.00005)
set(stage_case ${WORK}/stage.yaml)
set(stage_options --set time.end=0.002)
set(stream_case ${CASES}/powder_pouring_ci.yaml)
set(stream_options --set time.end=0.01 --set output.history_interval=0.001
                   --set output.checkpoint_interval=0.005 --set output.vtk_interval=0.005)
set(drum_case ${CASES}/rotating_drum_ci.yaml)
set(drum_options --set time.end=0.04 --set output.checkpoint_interval=0.02)
set(outputs history.csv final_state.csv last_good_state.csv checkpoint.bin clusters.csv layer.csv
            state_000000.csv state_000001.csv state_000003.csv layers.csv layer_001.csv
            layer_002.csv summary.txt)

# Open MPI refuses root without these (CI runs as root).
set(ENV{OMPI_ALLOW_RUN_AS_ROOT} 1)
set(ENV{OMPI_ALLOW_RUN_AS_ROOT_CONFIRM} 1)

# Runs bondem run with ARGN on `processes` processes (0: without mpirun); must exit with
# `expected_status` (0 when not set).
function(run_on processes)
  if(processes EQUAL 0)
    set(command ${BONDEM} run ${ARGN} --quiet)
  else()
    # --bind-to none: more processes than cores share them (CI has 2) instead of spinning on one.
    set(command ${MPIRUN} --oversubscribe --bind-to none -np ${processes} ${BONDEM} run ${ARGN}
                --quiet)
  endif()
  execute_process(COMMAND ${command} RESULT_VARIABLE status ERROR_VARIABLE err OUTPUT_VARIABLE out)
  if(NOT DEFINED expected_status)
    set(expected_status 0)
  endif()
  if(NOT status EQUAL expected_status)
    message(FATAL_ERROR "'${command}' exited with ${status}: ${err}")
  endif()
  set(run_output "${out}" PARENT_SCOPE)
  set(run_error "${err}" PARENT_SCOPE)
endfunction()

# The last run's printed summary into `directory`/summary.txt, without what depends on the
# machine, the directory, the threads or where the run resumed (the steps it took): the
# end-of-run figures (packing, clusters, heat) are in no file.
function(write_summary directory)
  string(REGEX REPLACE
         "(output_directory|threads|wall_time|particle_steps_per_second|steps) = [^\n]*\n" ""
         summary "${run_output}")
  file(WRITE ${directory}/summary.txt "${summary}")
endfunction()

# Every output of the reference run of `name` must be in `directory` with the same bytes.
function(expect_reference_bytes name directory what)
  foreach(output ${outputs})
    set(reference ${WORK}/../cli_mpi_run_0_work/${name}_0/${output})
    if(NOT EXISTS ${reference})
      continue()
    endif()
    execute_process(COMMAND ${CMAKE_COMMAND} -E compare_files ${reference} ${directory}/${output}
                    RESULT_VARIABLE differ)
    if(differ)
      message(FATAL_ERROR "${what}: ${output} differs from the run in one process")
    endif()
  endforeach()
endfunction()

foreach(name pour spreading thermal migration leaving laser drum stream stage)
  set(directory ${WORK}/${name}_${PROCESSES})
  file(REMOVE_RECURSE ${directory})
  run_on(${PROCESSES} ${${name}_case} ${${name}_options} --output ${directory})
  write_summary(${directory})
  if(PROCESSES EQUAL 0)
    if(NOT EXISTS ${directory}/checkpoint.bin)
      message(FATAL_ERROR "${name}: the reference run wrote no checkpoint")
    endif()
    if(name STREQUAL "spreading" AND NOT (EXISTS ${directory}/state_000003.csv AND
                                          EXISTS ${directory}/layer_002.csv))
      message(FATAL_ERROR "spreading: the reference run wrote no state snapshots or layers")
    endif()
  else()
    expect_reference_bytes(${name} ${directory} "${name} on ${PROCESSES} processes")
  endif()
endforeach()

# The VTK series of `directory`, whole or in pieces, frame by frame as the reference run's.
function(expect_reference_frames name directory what)
  execute_process(COMMAND ${FRAMES_MATCH} ${WORK}/../cli_mpi_run_0_work/${name}_0 ${directory}
                  RESULT_VARIABLE differ ERROR_VARIABLE err)
  if(differ)
    message(FATAL_ERROR "${what}: VTK frames differ from the run in one process: ${err}")
  endif()
endfunction()

# A blow-up: the pour at 13 times its time step limit (--unsafe-time-step) overlaps too far at
# step 250. Exit 3, and history.csv and last_good_state.csv (the state of the last history row,
# gathered from every process) with the bytes of the run in one process.
set(directory ${WORK}/blown_${PROCESSES})
file(REMOVE_RECURSE ${directory})
set(expected_status 3)
run_on(${PROCESSES} ${pour_case} --set time.step=2e-5 --unsafe-time-step
       --set output.history_interval=0.0002 --output ${directory})
unset(expected_status)
if(PROCESSES EQUAL 0)
  if(NOT EXISTS ${directory}/last_good_state.csv)
    message(FATAL_ERROR "the blown-up reference run wrote no last_good_state.csv")
  endif()
else()
  expect_reference_bytes(blown ${directory} "the blow-up on ${PROCESSES} processes")
  if(NOT EXISTS ${directory}/last_good_state.csv)
    message(FATAL_ERROR "the blow-up on ${PROCESSES} processes wrote no last_good_state.csv")
  endif()
endif()

if(NOT PROCESSES EQUAL 0)
  foreach(name pour laser drum stream)  # the series with frames; the drum's show the mesh as tools
    expect_reference_frames(${name} ${WORK}/${name}_${PROCESSES} "${name} on ${PROCESSES} processes")
  endforeach()

  # Stopped midway on PROCESSES processes, continued from the checkpoint on another number.
  math(EXPR next "${PROCESSES} % 4 + 1")
  set(directory ${WORK}/pour_restarted)
  file(REMOVE_RECURSE ${directory})
  set(halfway --set output.checkpoint_interval=0.0012 --set output.history_interval=0.0002
              --set output.vtk_interval=0.0006)
  run_on(${PROCESSES} ${pour_case} ${halfway} --set time.end=0.0012 --output ${directory})
  run_on(${next} ${pour_case} ${pour_options} --output ${directory}
         --restart ${directory}/checkpoint.bin)
  write_summary(${directory})
  expect_reference_bytes(pour ${directory}
                         "pour on ${PROCESSES} processes continued on ${next}")
  expect_reference_frames(pour ${directory} "pour on ${PROCESSES} processes continued on ${next}")

  # A checkpoint of another case is refused as such, before any process bisects its particles.
  set(expected_status 2)
  run_on(${PROCESSES} ${thermal_case} --output ${WORK}/wrong_case
         --restart ${directory}/checkpoint.bin)
  unset(expected_status)
  if(NOT run_error MATCHES "checkpoint was written by a different case")
    message(FATAL_ERROR "a checkpoint of another case on ${PROCESSES} processes: ${run_error}")
  endif()

  set(directory ${WORK}/stream_restarted)
  file(REMOVE_RECURSE ${directory})
  run_on(${PROCESSES} ${stream_case} ${stream_options} --set time.end=0.005 --output ${directory})
  run_on(${next} ${stream_case} ${stream_options} --output ${directory}
         --restart ${directory}/checkpoint.bin)
  write_summary(${directory})
  expect_reference_bytes(stream ${directory}
                         "stream on ${PROCESSES} processes continued on ${next}")
  expect_reference_frames(stream ${directory}
                          "stream on ${PROCESSES} processes continued on ${next}")
endif()
