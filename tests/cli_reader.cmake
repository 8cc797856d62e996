# Command-line checks of the case reader and --set: overlaps, materials, periodic axes, paths.
include(${CMAKE_CURRENT_LIST_DIR}/cli_common.cmake)
file(REMOVE_RECURSE ${WORK})
file(MAKE_DIRECTORY ${WORK})

# Item 10: every malformed --set path is blamed on that --set, on one line, without C++ internals.
expect_bad_input("--set a.=1: empty component" info ${CASES}/paper_5_1.yaml --set a.=1)
expect_bad_input("--set time.end.=1e-4: empty component" run ${CASES}/paper_5_1.yaml --quiet
                 --set time.end.=1e-4 --output ${WORK}/run_trailing_dot)
expect_bad_input("--set particles.99999999999999999999.radius=1: 'particles.99999999999999999999' is not an index"
                 info ${CASES}/paper_5_1.yaml --set particles.99999999999999999999.radius=1)

# Item 7: a material defined twice, and a material whose key is not a name.
file(READ ${CASES}/paper_5_1.yaml paper)
string(REPLACE "materials:\n" "materials:\n  powder: {density: 9000, youngs_modulus: 2.0e9, poisson_ratio: 0.3}\n"
               twice "${paper}")
file(WRITE ${WORK}/material_twice.yaml "${twice}")
expect_bad_input("material_twice.yaml:7:3: 'materials.powder': material defined twice"
                 info ${WORK}/material_twice.yaml)
string(REPLACE "materials:\n" "materials:\n  ? {x: 1}\n  : {density: 1, youngs_modulus: 1, poisson_ratio: 0}\n"
               complex_key "${paper}")
file(WRITE ${WORK}/material_key.yaml "${complex_key}")
expect_bad_input("'materials': a material's name must be a plain, non-empty name"
                 info ${WORK}/material_key.yaml)

# Item 8: a periodic axis long enough for three neighbor cells runs (the grid's memory cap used to
# widen all cells alike and refuse it, exit 1); one too short is a reader error naming the key,
# in info as in run.
execute_process(COMMAND ${BONDEM} run ${CASES}/powder_spreading_ci.yaml --quiet
                        --set insert.0.count=3 --set time.end=3e-7 --output ${WORK}/spread_three
                RESULT_VARIABLE status ERROR_VARIABLE err OUTPUT_QUIET)
if(NOT status EQUAL 0)
  message(FATAL_ERROR "a valid periodic axis was refused (exit ${status}): ${err}")
endif()
expect_bad_input("--set neighbors.skin=0.001: 'neighbors.skin': periodic axis y of length 0.00025 m"
                 info ${CASES}/laser_sintering_ci.yaml --set neighbors.skin=0.001)
expect_bad_input("--set neighbors.skin=0.001: 'neighbors.skin': periodic axis y"
                 run ${CASES}/laser_sintering_ci.yaml --quiet --set neighbors.skin=0.001
                 --output ${WORK}/short_axis)
if(EXISTS ${WORK}/short_axis)
  message(FATAL_ERROR "a refused case left ${WORK}/short_axis behind")
endif()

# Item 6: initial overlaps beyond limits.max_overlap_fraction are refused before any step; the
# peer lattice's deliberate 1 um overlap (also across its periodic faces) stays accepted.
execute_process(COMMAND ${BONDEM} info ${CASES}/bench/peer_lattice.yaml RESULT_VARIABLE status
                OUTPUT_QUIET ERROR_VARIABLE err)
if(NOT status EQUAL 0)
  message(FATAL_ERROR "peer_lattice.yaml was refused: ${err}")
endif()
expect_bad_input("'insert.0.spacing': neighbors of the lattice overlap by 0.5 of their radius"
                 run ${CASES}/bench/peer_lattice.yaml --quiet --set insert.0.spacing=0.0015
                 --output ${WORK}/lattice_overlap)
# A lattice laid over an explicit particle.
file(READ ${CASES}/paper_5_1.yaml pair)
string(APPEND pair "insert:\n  - {type: lattice, region: {min: [-0.002, -0.001, -0.001], max: [0.0, 0.001, 0.001]}, spacing: 0.002, radius: 0.001, material: powder}\n")
file(WRITE ${WORK}/lattice_over_particle.yaml "${pair}")
expect_bad_input("lattice_over_particle.yaml:28:5: 'insert.0': its particle at [-0.001, 0, 0] overlaps particles.0 by 1 of the smaller radius"
                 run ${WORK}/lattice_over_particle.yaml --quiet --output ${WORK}/over_particle)
# Counts are checked before anything is allocated: a lattice of 10^20 spheres, and a random fill
# of 10^8 in a small region (which took 15-18 s and 1 GB before it was refused).
expect_bad_input("'insert.0.spacing': gives" info ${CASES}/bench/peer_lattice.yaml
                 --set insert.0.spacing=1e-9)
expect_bad_input("--set insert.0.count=100000000: 'insert.0': random fill: count 100000000 even at the smallest possible radius"
                 info ${CASES}/powder_bed_packing_ci.yaml --set insert.0.count=100000000)
