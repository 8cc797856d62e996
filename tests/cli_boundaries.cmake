# Boundaries from the command line: a mesh case runs, its history has the mesh's load and moment;
# bad mesh files and impossible motions exit 2 with one line naming the key, and leave nothing.
include(${CMAKE_CURRENT_LIST_DIR}/cli_common.cmake)
set(WORK ${WORK}/boundaries)
file(REMOVE_RECURSE ${WORK})
file(MAKE_DIRECTORY ${WORK}/geometry)
file(COPY ${CASES}/geometry/drum.stl DESTINATION ${WORK}/geometry)

# A few spheres falling into a drum that starts turning; the file is relative to the case.
set(drum_case "materials:
  glass: {density: 2500, youngs_modulus: 1.0e7, poisson_ratio: 0.3}
contact: {damping_ratio: 0.2, friction: 0.5}
gravity: [0.0, 0.0, -9.81]
domain: {min: [-0.0055, -0.0012, -0.0055], max: [0.0055, 0.0012, 0.0055]}
walls:
  - type: mesh
    file: geometry/drum.stl
    scale: 1.0e-3
    material: glass
    name: drum
    motion: {axis: [0, 1, 0], keys: [{time: 0.0, angular_velocity: 2.0}]}
particles:
  - {material: glass, radius: 0.0003, position: [0.0, 0.0, -0.0046]}
  - {material: glass, radius: 0.0003, position: [0.001, 0.0, -0.0045]}
time: {step: 2.0e-7, end: 2.0e-3}
")
file(WRITE ${WORK}/drum.yaml "${drum_case}")
expect_success(run ${WORK}/drum.yaml --quiet --output ${WORK}/drum_out)
file(STRINGS ${WORK}/drum_out/history.csv history LIMIT_COUNT 1)
foreach(column load_drum_x load_drum_z moment_drum_y)
  string(FIND "${history}" "${column}" at)
  if(at EQUAL -1)
    message(FATAL_ERROR "history.csv lacks ${column}: ${history}")
  endif()
endforeach()

# info lists every boundary; a mesh with its triangle count and where it sits (the check of an
# STL file's scale): the drum's 96-gon spans 5 mm either side of the axis.
expect_success(info ${WORK}/drum.yaml)
expect_text("${out}" "[boundary drum]\nshape = mesh\ntriangles = 384\n" "mesh section")
expect_text("${out}" "bounding_box = [-0.005 -0.001 -0.005] .. [0.005 0.001 0.005] m" "mesh box")

# Bad mesh files: missing, empty, not STL, no facet of any area.
file(WRITE ${WORK}/geometry/empty.stl "")
file(WRITE ${WORK}/geometry/text.stl "hello, not a mesh\n")
file(WRITE ${WORK}/geometry/flat.stl "solid flat
facet normal 0 0 1
outer loop
vertex 0 0 0
vertex 1 0 0
vertex 2 0 0
endloop
endfacet
endsolid flat
")
foreach(bad "missing.stl|no such file" "empty.stl|empty file" "text.stl|not an STL file"
            "flat.stl|no facet with a non-zero area")
  string(REPLACE "|" ";" pair "${bad}")
  list(GET pair 0 name)
  list(GET pair 1 reason)
  expect_bad_input("'walls.0.file': ${WORK}/geometry/${name}: ${reason}" run ${WORK}/drum.yaml
                   --quiet --set walls.0.file=geometry/${name} --output ${WORK}/run_${name})
endforeach()
expect_bad_input("'walls.0.scale'" run ${WORK}/drum.yaml --quiet --set walls.0.scale=-1
                 --output ${WORK}/run_scale)

# Motions a shape cannot take, and malformed tables.
file(READ ${CASES}/powder_spreading_ci.yaml spreading)
string(REPLACE "name: substrate}" "name: substrate, motion: {axis: [0, 0, 1], spin: 1.0}}"
       spinning_plane "${spreading}")
file(WRITE ${WORK}/spinning_plane.yaml "${spinning_plane}")
expect_bad_input("'walls.0.motion': a plane cannot rotate" run ${WORK}/spinning_plane.yaml --quiet
                 --output ${WORK}/run_spinning_plane)
string(REPLACE "velocity: [0.1, 0.0, 0.0]}" "velocity: [0.1, 0.0, 0.0], angular_velocity: 3}"
       turning_blade "${spreading}")
file(WRITE ${WORK}/turning_blade.yaml "${turning_blade}")
expect_bad_input("'walls.2.motion': a rotation needs an axis" run ${WORK}/turning_blade.yaml
                 --quiet --output ${WORK}/run_turning_blade)
expect_bad_input("'walls.0.motion.interpolation': unknown interpolation 'cubic'" run
                 ${WORK}/drum.yaml --quiet --set walls.0.motion.interpolation=cubic
                 --output ${WORK}/run_cubic)
expect_bad_input("'walls.0.motion.keys.0.spin': unknown key" run ${WORK}/drum.yaml --quiet
                 --set walls.0.motion.keys.0.spin=1 --output ${WORK}/run_key_typo)
# VTK's STL reader is a module loaded on first use (io/vtk_module.hpp): one that cannot be
# loaded fails the run with the place tried and the variable that names another, leaving nothing.
execute_process(COMMAND ${CMAKE_COMMAND} -E env BONDEM_VTK_MODULE=${WORK}/no_such_module.so
                        ${BONDEM} run ${WORK}/drum.yaml --quiet --output ${WORK}/run_no_module
                RESULT_VARIABLE status ERROR_VARIABLE err OUTPUT_QUIET)
if(status EQUAL 0)
  message(FATAL_ERROR "a run without its VTK module succeeded")
endif()
expect_text("${err}" "cannot load bondem's VTK module libbondem_vtk.so (set BONDEM_VTK_MODULE"
            "missing module")
expect_text("${err}" "${WORK}/no_such_module.so" "missing module's path")
file(GLOB leftovers ${WORK}/run_*)
if(leftovers)
  message(FATAL_ERROR "refused runs left output behind: ${leftovers}")
endif()
