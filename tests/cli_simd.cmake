# The SIMD pass gives the same bytes on every target and thread count (pair_kernel_simd.hpp):
# the peer lattice (friction), a spreading CI variant (friction, rolling resistance, a blade), a
# bonded case and a cohesive one (JKR: the scalar pass, which must not depend on --simd either)
# run on every target this CPU supports at one thread, and on the best at two; final_state.csv
# and history.csv must match the scalar target's byte for byte. Also: --simd errors, and the
# banner and `bondem info` name the pass and target.
include(${CMAKE_CURRENT_LIST_DIR}/cli_common.cmake)
file(REMOVE_RECURSE ${WORK})
file(MAKE_DIRECTORY ${WORK})

expect_bad_input("--simd neon: unknown target" run ${CASES}/paper_5_1.yaml --simd neon)
expect_bad_input("--simd neon: unknown target" info ${CASES}/paper_5_1.yaml --simd neon)

# The targets this CPU supports: a target it lacks exits 2 naming the supported ones.
set(targets "")
foreach(target scalar sse4 avx2 avx512)
  execute_process(COMMAND ${BONDEM} info ${CASES}/paper_5_1.yaml --simd ${target}
                  RESULT_VARIABLE status OUTPUT_VARIABLE out ERROR_VARIABLE err)
  if(status EQUAL 0)
    expect_text("${out}" "pair pass SIMD ${target}" "bondem info --simd ${target}")
    list(APPEND targets ${target})
  else()
    expect_text("${err}" "is not supported by this CPU (supported: scalar" "--simd ${target}")
  endif()
endforeach()
list(GET targets 0 first_target)
if(NOT first_target STREQUAL "scalar")
  message(FATAL_ERROR "the scalar target must always be available, got: ${targets}")
endif()
message(STATUS "targets on this CPU: ${targets}")

# name | case | overrides (comma-separated) | the pass the case must take. Shortened for CI; the
# spreading blade starts at 0.5 ms instead of 20 ms, so that it pushes the falling powder.
set(runs
    "lattice|bench/peer_lattice.yaml|time.end=1e-4|SIMD"
    "spreading|powder_spreading_ci.yaml|time.end=0.0015,walls.2.motion.1.time=0.0005|SIMD"
    "bonded|paper_5_1.yaml|time.end=0.003|SIMD"
    "cohesive|powder_spreading_cohesive_ci.yaml|time.end=0.0015|scalar (JKR cohesion)")
foreach(run IN LISTS runs)
  string(REPLACE "|" ";" fields "${run}")
  list(GET fields 0 name)
  list(GET fields 1 case_file)
  list(GET fields 2 override_list)
  string(REPLACE "," ";" overrides "${override_list}")
  set(set_arguments "")
  foreach(override IN LISTS overrides)
    list(APPEND set_arguments --set ${override})
  endforeach()
  list(GET fields 3 pass)
  set(variants "")
  foreach(target IN LISTS targets)
    list(APPEND variants "${target}:1")
  endforeach()
  list(APPEND variants "auto:2")
  foreach(variant IN LISTS variants)
    string(REPLACE ":" ";" parts "${variant}")
    list(GET parts 0 target)
    list(GET parts 1 threads)
    set(dir ${WORK}/${name}_${target}_${threads})
    expect_success(run ${CASES}/${case_file} ${set_arguments} --simd ${target} --threads
                   ${threads} --output ${dir})
    expect_text("${err}" "pair pass ${pass}" "banner of ${name} on ${target}")
    foreach(file final_state.csv history.csv)
      execute_process(COMMAND ${CMAKE_COMMAND} -E compare_files ${WORK}/${name}_scalar_1/${file}
                              ${dir}/${file} RESULT_VARIABLE differs)
      if(differs)
        message(FATAL_ERROR "${name}: ${file} on --simd ${target} --threads ${threads} differs "
                            "from --simd scalar --threads 1")
      endif()
    endforeach()
  endforeach()
endforeach()
