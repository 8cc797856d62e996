# bench/compare_rounds.awk, the rounds table of bench/compare_peers.sh, on a timings file of two
# hand-made rounds whose ratios are worked out below: bondem against the faster peer, two cores
# over one, the two-core bounds (each CPU alone, both busy) and the split by the vCPUs'
# placement. The README's speed-up figures come from this table.
include(${CMAKE_CURRENT_LIST_DIR}/cli_common.cmake)
file(REMOVE_RECURSE ${WORK})
file(MAKE_DIRECTORY ${WORK})
# lattice,code,cores,round,wall_s,wall_rate,loop_rate,peak_kib,core_ns_before,core_ns_after
file(WRITE ${WORK}/timings.csv
"20k,bondem,1,1,1.50,0,0,0,,
20k,liggghts,1,1,5.80,0,0,0,,
20k,lammps,1,1,5.40,0,0,0,,
20k,bondem-second,1,1,1.25,0,0,0,,
20k,bondem-pair-first,1,1,1.55,0,0,0,,
20k,bondem-pair-second,1,1,1.70,0,0,0,,
20k,bondem,2,1,0.90,0,0,0,150,160
20k,liggghts,2,1,3.40,0,0,0,30,40
20k,lammps,2,1,3.30,0,0,0,150,160
20k,bondem,1,2,1.60,0,0,0,,
20k,liggghts,1,2,6.00,0,0,0,,
20k,lammps,1,2,4.80,0,0,0,,
20k,bondem-second,1,2,1.60,0,0,0,,
20k,bondem-pair-first,1,2,1.60,0,0,0,,
20k,bondem-pair-second,1,2,1.60,0,0,0,,
20k,bondem,2,2,1.00,0,0,0,30,40
20k,liggghts,2,2,3.00,0,0,0,150,160
20k,lammps,2,2,3.00,0,0,0,150,40
1m,bondem,1,1,9.99,0,0,0,,
")
find_program(AWK awk REQUIRED)
execute_process(COMMAND ${AWK} -F, -v l=20k -f ${BENCH}/compare_rounds.awk ${WORK}/timings.csv
                RESULT_VARIABLE status OUTPUT_VARIABLE table ERROR_VARIABLE err)
if(NOT status EQUAL 0)
  message(FATAL_ERROR "compare_rounds.awk failed (${status}): ${err}")
endif()
# One core: 5.40 / 1.50 and 4.80 / 1.60. Two cores: 3.30 / 0.90 and 3.00 / 1.00.
expect_text("${table}" "| 20k | bondem / faster peer, 1 core | 3.60, 3.00 | 3.30 |" "one core")
expect_text("${table}" "| 20k | bondem / faster peer, 2 cores | 3.67, 3.00 | 3.33 |" "two cores")
# 1.50 / 0.90 and 1.60 / 1.00.
expect_text("${table}" "| 20k | bondem two cores over one | 1.67, 1.60 | 1.63 |" "two over one")
# Each CPU alone: 1 + 1.50 / 1.25 and 1 + 1.60 / 1.60; bondem's 1.67 and 1.60 against them.
expect_text("${table}" "would give (bondem's one-core runs on each) | 2.20, 2.00 | 2.10 |" "bound, alone")
expect_text("${table}" "| 20k | bondem two cores over one, against that bound | 0.76, 0.80 | 0.78 |"
            "against the bound, alone")
# Both busy: 1.50 (1 / 1.55 + 1 / 1.70) = 1.850 and 1.60 (2 / 1.60) = 2.
expect_text("${table}" "(two one-core runs at once, one on each) | 1.85, 2.00 | 1.93 |" "bound, both busy")
expect_text("${table}" "| 20k | bondem two cores over one, against the bound with both busy | 0.90, 0.80 | 0.85 |"
            "against the bound, both busy")
# By placement: round 1's bondem and LAMMPS two-core runs far, LIGGGHTS's near; round 2 the other
# way round, and its LAMMPS run (one probe each way) in neither.
expect_text("${table}" "| 20k | bondem two cores over one, vCPUs on different dies (core to core > 100 ns) | 1.67 | 1.67 |"
            "bondem far")
expect_text("${table}" "| 20k | bondem two cores over one, vCPUs sharing a cache (core to core < 100 ns) | 1.60 | 1.60 |"
            "bondem near")
expect_text("${table}" "| 20k | lammps two cores over one, vCPUs on different dies (core to core > 100 ns) | 1.64 | 1.64 |"
            "LAMMPS far")
expect_text("${table}" "| 20k | liggghts two cores over one, vCPUs sharing a cache (core to core < 100 ns) | 1.71 | 1.71 |"
            "LIGGGHTS near")
expect_text("${table}" "| 20k | liggghts two cores over one, vCPUs on different dies (core to core > 100 ns) | 2.00 | 2.00 |"
            "LIGGGHTS far")
foreach(unexpected "lammps two cores over one, vCPUs sharing a cache" "| 1m |")
  string(FIND "${table}" "${unexpected}" found)
  if(NOT found EQUAL -1)
    message(FATAL_ERROR "'${unexpected}' in the table (a run with one probe each way counted as "
                        "near, or another lattice's rows):\n${table}")
  endif()
endforeach()
