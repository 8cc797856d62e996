# Runs the bondem executable on bad input: each call must exit with status 2, print one line
# naming the problem, and leave no output file behind.
include(${CMAKE_CURRENT_LIST_DIR}/cli_common.cmake)
file(REMOVE_RECURSE ${WORK})
file(MAKE_DIRECTORY ${WORK})
file(READ ${CASES}/paper_5_1.yaml valid)
string(REPLACE "damping_ratio: 0.5" "damping_ratoi: 0.5" typo "${valid}")
file(WRITE ${WORK}/typo.yaml "${typo}")
# A thermal case (lines 27-33) whose laser absorptivity is out of range.
file(WRITE ${WORK}/laser.yaml "${valid}thermal: {initial_temperature: 300}
laser:
  power: 100
  spot_radius: 5.0e-5
  absorptivity: 1.5
  path:
    - {from: [0.0, 0.0], to: [0.002, 0.0], speed: 0.5}
")

expect_bad_input("typo.yaml:17:3: 'bond.damping_ratoi': unknown key" info ${WORK}/typo.yaml)
expect_bad_input("cannot open" info ${WORK}/missing.yaml)
expect_bad_input("--set materials.powder.density=abc" collide ${CASES}/paper_5_1.yaml
                 --velocity 1 --set materials.powder.density=abc)
expect_bad_input("exactly one of" collide ${CASES}/paper_5_1.yaml)
expect_bad_input("need 0 < V0 < V1" collide ${CASES}/paper_5_1.yaml --sweep 3:1:4
                 --out ${WORK}/sweep.csv)
expect_bad_input("--velocity" collide ${CASES}/paper_5_1.yaml --velocity fast)
# A non-finite speed ran as a collision at 0 m/s (--velocity 1e300) or failed with a message about
# radii (inf, nan).
foreach(speed inf nan 1e+300)
  expect_bad_input("--velocity ${speed}: need a positive speed below the speed of light" collide
                   ${CASES}/paper_5_1.yaml --velocity ${speed})
endforeach()
expect_bad_input("below the speed of light" collide ${CASES}/paper_5_1.yaml --sweep 1:inf:3
                 --out ${WORK}/sweep_inf.csv)
# A run that fails part-way must not leave a truncated file.
expect_bad_input("positive" collide ${CASES}/paper_5_1.yaml --velocity -1
                 --trace ${WORK}/trace.csv)
file(GLOB leftovers ${WORK}/trace.csv* ${WORK}/sweep.csv*)
if(leftovers)
  message(FATAL_ERROR "failed runs left files behind: ${leftovers}")
endif()

# bondem run refuses bad cases before starting and writes nothing.
expect_bad_input("'time.step'" run ${CASES}/powder_bed_packing_ci.yaml --quiet
                 --set time.step=1e-5 --output ${WORK}/run_dt)
expect_bad_input("'insert.0': random fill" run ${CASES}/powder_bed_packing_ci.yaml --quiet
                 --set insert.0.count=20000 --output ${WORK}/run_fill)
expect_bad_input("'particles.1': overlaps particles.0" run ${CASES}/paper_5_1.yaml --quiet
                 --set particles.1.position.0=0.0015 --output ${WORK}/run_overlap)
expect_bad_input("laser.yaml:31:17: 'laser.absorptivity': must lie in [0, 1], got 1.5" run
                 ${WORK}/laser.yaml --quiet --output ${WORK}/run_laser)
expect_bad_input("'bond.criterion': needs a thermal: block" run ${CASES}/paper_5_1.yaml --quiet
                 --set bond.criterion=temperature --output ${WORK}/run_criterion)
expect_bad_input("--threads must be at least 1" run ${CASES}/powder_bed_packing_ci.yaml --quiet
                 --threads 0 --output ${WORK}/run_threads)
# Under mpirun, a bad case is refused before anything is written: exit 2, the reason printed
# once (by rank 0), not once a process.
find_program(MPIRUN mpirun)
if(MPIRUN)
  # Open MPI refuses root without these (CI runs as root).
  set(ENV{OMPI_ALLOW_RUN_AS_ROOT} 1)
  set(ENV{OMPI_ALLOW_RUN_AS_ROOT_CONFIRM} 1)
  execute_process(COMMAND ${MPIRUN} --oversubscribe --bind-to none -np 2 ${BONDEM} run
                          ${WORK}/laser.yaml --quiet --output ${WORK}/run_mpirun
                  RESULT_VARIABLE status ERROR_VARIABLE err OUTPUT_VARIABLE out)
  if(NOT status EQUAL 2)
    message(FATAL_ERROR "mpirun -np 2 bondem run with a bad case: expected exit 2, got ${status}: "
                        "${err}")
  endif()
  set(reason "laser.yaml:31:17: 'laser.absorptivity': must lie in [0, 1], got 1.5")
  string(REGEX MATCHALL "'laser.absorptivity'" reasons "${err}")
  list(LENGTH reasons times)
  if(NOT times EQUAL 1)
    message(FATAL_ERROR "mpirun -np 2: expected '${reason}' once, got: ${err}")
  endif()
  expect_text("${err}" "${reason}" "mpirun -np 2")
endif()
file(GLOB run_leftovers ${WORK}/run_*)
if(run_leftovers)
  message(FATAL_ERROR "refused runs left output behind: ${run_leftovers}")
endif()

# Thread counts beyond 4 x the hardware threads are refused, from --threads or from the
# environment (the count with the issue's case crashed the neighbor build, 50 000 aborted).
expect_bad_input("--threads 100000 exceeds the limit of" run ${CASES}/powder_bed_packing_ci.yaml
                 --quiet --set insert.0.count=2100 --set time.end=3e-6 --threads 100000
                 --output ${WORK}/run_many_threads)
set(ENV{OMP_NUM_THREADS} 100000)
expect_bad_input("OMP_NUM_THREADS asks for 100000 threads, above the limit of" run
                 ${CASES}/paper_5_1.yaml --quiet --output ${WORK}/run_env_threads)
# --threads overrides the environment.
execute_process(COMMAND ${BONDEM} run ${CASES}/paper_5_1.yaml --quiet --threads 1
                --set time.end=1e-6 --output ${WORK}/env_overridden RESULT_VARIABLE env_status
                OUTPUT_QUIET ERROR_VARIABLE env_err)
if(NOT env_status EQUAL 0)
  message(FATAL_ERROR "--threads 1 should override OMP_NUM_THREADS=100000: ${env_err}")
endif()
unset(ENV{OMP_NUM_THREADS})

# Command-line parse errors: exit 2, one line.
expect_bad_input("--set: 1 required" run ${CASES}/paper_5_1.yaml --quiet --set)
expect_bad_input("not expected: extra.yaml" run ${CASES}/paper_5_1.yaml extra.yaml --quiet)
expect_bad_input("--set time.end=abc" run --set time.end=abc ${CASES}/paper_5_1.yaml --quiet
                 --output ${WORK}/run_set_first)

# Analysis settings that used to fail only after the last step are refused before step 0.
expect_bad_input("'analysis.layer.grid_spacing': the surface grid would have" run
                 ${CASES}/powder_spreading_ci.yaml --quiet --set analysis.layer.grid_spacing=1e-12
                 --output ${WORK}/run_grid)
expect_bad_input("'analysis.layer.substrate_z': the layer lies outside the domain along z" run
                 ${CASES}/powder_spreading_ci.yaml --quiet --set analysis.layer.substrate_z=5
                 --output ${WORK}/run_layer_outside)
file(READ ${CASES}/powder_bed_packing_ci.yaml packing)
file(WRITE ${WORK}/region.yaml "${packing}analysis:
  region: {min: [0.003, 0.003, 0.003], max: [0.009, 0.009, 0.009]}
")
execute_process(COMMAND ${BONDEM} info ${WORK}/region.yaml RESULT_VARIABLE region_status
                OUTPUT_QUIET ERROR_VARIABLE region_err)
if(NOT region_status EQUAL 0)
  message(FATAL_ERROR "a valid analysis.region was refused: ${region_err}")
endif()
expect_bad_input("'analysis.region': lies outside the domain along x" run ${WORK}/region.yaml
                 --quiet --set analysis.region.min.0=0.02 --set analysis.region.max.0=0.03
                 --output ${WORK}/run_region_outside)
expect_bad_input("mean particle diameters along z; a solid fraction needs at least 3" run
                 ${WORK}/region.yaml --quiet --set analysis.region.max.2=0.004
                 --output ${WORK}/run_region_thin)
file(GLOB run_leftovers ${WORK}/run_*)
if(run_leftovers)
  message(FATAL_ERROR "refused runs left output behind: ${run_leftovers}")
endif()


# --set is accepted before the case file by every subcommand (it used to swallow the file).
expect_success(run --set time.end=1e-6 ${CASES}/paper_5_1.yaml --quiet --output ${WORK}/set_first)
expect_text("${out}" "steps = 2\n" "run --set first")
expect_success(info --set bond.damping_ratio=0.25 ${CASES}/paper_5_1.yaml)
expect_text("${out}" "[powder powder]" "info --set first")
expect_success(collide --set time.end=1e-6 ${CASES}/paper_5_1.yaml --velocity 1)
expect_text("${out}" "restitution = " "collide --set first")

# The banner and the threads line report the threads that run: below 1024 particles the loops
# run serially whatever --threads says; above, the team asked for.
expect_success(run ${CASES}/paper_5_1.yaml --threads 2 --set time.end=1e-6 --output ${WORK}/two)
expect_text("${err}" "2 particles, 1 thread (below 1024 particles" "serial banner")
expect_text("${out}" "threads = 1\n" "serial threads line")
expect_success(run ${CASES}/powder_bed_packing_ci.yaml --threads 2 --set insert.0.count=2100
               --set time.end=3e-6 --output ${WORK}/many)
expect_text("${err}" "2100 particles, 2 threads, pair pass " "parallel banner")
expect_text("${out}" "threads = 2\n" "parallel threads line")

# A bed region with no volume (a case without a domain: the margins invert the default region)
# is reported as such, not as a solid fraction of -0; `name = value` lines stay parseable.
expect_success(run ${CASES}/paper_5_1.yaml --quiet --set time.end=1e-6 --output ${WORK}/apart)
expect_text("${out}" "\nbed_solid_fraction = n/a (the region is empty along z" "inverted bed")
expect_text("${out}" "\nmean_coordination = n/a (the region is empty along z" "inverted bed")

# Clusters are bonded agglomerates of two or more particles, on stdout as in clusters.csv; the
# particles with no bond are counted apart. The pair apart: no cluster (it printed 2 clusters).
expect_text("${out}" "\nclusters = 0\nunbonded_particles = 2\nlargest_cluster = 0\n" "pair apart")
file(READ ${WORK}/apart/clusters.csv apart_clusters)
if(NOT apart_clusters STREQUAL "cluster,particles,volume_equivalent_diameter\n")
  message(FATAL_ERROR "pair apart: clusters.csv should hold only its header: ${apart_clusters}")
endif()
# The pair bonded: one cluster of two, row 0 of clusters.csv.
expect_success(run ${CASES}/paper_5_1.yaml --quiet --output ${WORK}/bonded)
expect_text("${out}" "\nclusters = 1\nunbonded_particles = 0\nlargest_cluster = 2\n" "bonded pair")
file(STRINGS ${WORK}/bonded/clusters.csv bonded_rows)
list(LENGTH bonded_rows bonded_row_count)
list(GET bonded_rows 1 bonded_row)
if(NOT bonded_row_count EQUAL 2 OR NOT bonded_row MATCHES "^0,2,")
  message(FATAL_ERROR "bonded pair: clusters.csv should hold one cluster 0 of 2: ${bonded_rows}")
endif()
