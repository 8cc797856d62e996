# Command-line checks of the time-step guard, info and the end-of-run report.
include(${CMAKE_CURRENT_LIST_DIR}/cli_common.cmake)
file(REMOVE_RECURSE ${WORK})
file(MAKE_DIRECTORY ${WORK})

# Runs bondem with ARGN and returns its exit status, stdout and stderr in the caller's
# status, out and err.
macro(run_bondem)
  execute_process(COMMAND ${BONDEM} ${ARGN} RESULT_VARIABLE status OUTPUT_VARIABLE out
                  ERROR_VARIABLE err)
endmacro()

# Item 4: a speed that overflows the derived quantities is an input error naming the key, not a
# NaN time-step limit that lets the run through.
expect_bad_input("'particles.0.velocity'" info ${CASES}/paper_5_1.yaml
                 --set particles.0.velocity.0=1e300)
expect_bad_input("'particles.0.velocity'" run ${CASES}/paper_5_1.yaml --quiet
                 --output ${WORK}/fast --set particles.0.velocity.0=1e300)
if(EXISTS ${WORK}/fast/history.csv)
  message(FATAL_ERROR "a refused run left ${WORK}/fast/history.csv behind")
endif()
expect_bad_input("contact.damping_ratio = 1e+300" run ${CASES}/paper_5_1.yaml --quiet
                 --output ${WORK}/absurd_damping --set contact.damping_ratio=1e300)

# Item 5: a damper too stiff for the time step is refused, naming time.step and the damper.
foreach(expected "'time.step'" "stability of the contact damper (contact.damping_ratio = 1000)")
  expect_bad_input("${expected}" run ${CASES}/paper_5_1.yaml --quiet --output ${WORK}/damper
                   --set contact.damping_ratio=1000 --set time.end=1e-4)
endforeach()
expect_bad_input("bond damper (bond.damping_ratio = 1000)" run ${CASES}/paper_5_1.yaml --quiet
                 --output ${WORK}/damper --set bond.damping_ratio=1000 --set time.end=1e-4)

# Item 11: without a bond block info prints no bond quantities (the reader's placeholder).
file(WRITE ${WORK}/no_bond.yaml [=[
materials:
  glass: {density: 2500, youngs_modulus: 1.0e9, poisson_ratio: 0.3}
contact: {damping_ratio: 0.2}
particles:
  - {material: glass, radius: 0.001, position: [0.0, 0.0, 0.0], velocity: [1.0, 0.0, 0.0]}
  - {material: glass, radius: 0.001, position: [0.003, 0.0, 0.0]}
time: {step: 1.0e-7, end: 1.0e-4}
]=])
run_bondem(info ${WORK}/no_bond.yaml)
if(NOT status EQUAL 0)
  message(FATAL_ERROR "info on a case without bond failed (${status}): ${err}")
endif()
foreach(placeholder equilibrium_overlap critical_velocity bond_period adhesion_stiffness " inf ")
  string(FIND "${out}" "${placeholder}" found)
  if(NOT found EQUAL -1)
    message(FATAL_ERROR "info without a bond block prints '${placeholder}':\n${out}")
  endif()
endforeach()

# Docs item: info prints the restitution of xi_con; 0.197 gives 0.5498 (Restitution.MatchesACollideRun
# checks the value against collide).
run_bondem(info ${CASES}/bench/peer_lattice.yaml)
if(NOT out MATCHES "contact_restitution = 0\\.549[0-9]*\n")
  message(FATAL_ERROR "info lacks contact_restitution = 0.549...:\n${out}")
endif()

# Item 15: a tool's speed enters the limit: a blade at 1e5 m/s is refused, naming it.
expect_bad_input("tool 'blade'" run ${CASES}/powder_spreading_ci.yaml --quiet
                 --output ${WORK}/blade --set walls.2.motion.1.velocity.0=1e5)
# Forced past the limit, the blow-up names the tool and particle, and blames the time step.
run_bondem(run ${CASES}/powder_spreading_ci.yaml --quiet --output ${WORK}/blade
           --unsafe-time-step --set walls.2.motion.0.velocity.0=100 --set time.end=1e-6)
if(NOT status EQUAL 3)
  message(FATAL_ERROR "expected a blow-up (3) from a blade at 100 m/s, got ${status}: ${err}")
endif()
foreach(expected "in tool 'blade'" "particle id " "above its limit")
  string(FIND "${err}" "${expected}" found)
  if(found EQUAL -1)
    message(FATAL_ERROR "the blade's blow-up message lacks '${expected}': ${err}")
  endif()
endforeach()

# Item 15: within its limit, a tool pressing a particle into the floor blows the run up; the
# message names the tool and the particle and does not blame the time step.
file(WRITE ${WORK}/press.yaml [=[
materials:
  glass: {density: 2500, youngs_modulus: 1.0e9, poisson_ratio: 0.3}
contact: {damping_ratio: 0.2}
walls:
  - {type: plane, point: [0.0, 0.0, 0.0], normal: [0.0, 0.0, 1.0], material: glass, name: floor}
  - type: blade
    name: press
    min: [-0.002, -0.002, 0.0021]
    max: [0.002, 0.002, 0.003]
    material: glass
    motion:
      - {time: 0.0, velocity: [0.0, 0.0, -1.0]}
particles:
  - {material: glass, radius: 0.001, position: [0.0, 0.0, 0.001]}
time: {step: 4.0e-7, end: 1.0e-3}  # within the limit of 5.6e-7 s, above half of it
]=])
run_bondem(run ${WORK}/press.yaml --quiet --output ${WORK}/press)
if(NOT status EQUAL 3)
  message(FATAL_ERROR "expected a blow-up (3) from the press, got ${status}: ${err}")
endif()
foreach(expected "particle id 0 in tool 'press'" "time.step is within its limit"
                 "the tool named above drives particles")
  string(FIND "${err}" "${expected}" found)
  if(found EQUAL -1)
    message(FATAL_ERROR "the press's blow-up message lacks '${expected}': ${err}")
  endif()
endforeach()
string(FIND "${err}" "try a smaller step" found)
if(NOT found EQUAL -1)
  message(FATAL_ERROR "a time step within its limit is blamed: ${err}")
endif()
