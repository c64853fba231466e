# install.consumer (tests/install/CMakeLists.txt): installs the build into a fresh prefix,
# builds tests/install/consumer/ against the installed CMake package and runs it, then runs
# the installed rayline from another working directory with no data-folder variables set:
# it must find its platforms and scene profiles under <prefix>/share/rayline.
#   cmake -DBUILD_DIR=... -DSOURCE_DIR=... -DWORK_DIR=... -DGENERATOR=... -DCXX=...
#         [-DCXX_FLAGS=...] [-DLAUNCHER=ccache] -P check_install.cmake
set(prefix ${WORK_DIR}/prefix)
set(rayline ${prefix}/bin/rayline)
file(REMOVE_RECURSE ${WORK_DIR})
file(MAKE_DIRECTORY ${WORK_DIR}/elsewhere)

# run(NAME OUT_VAR cmd...): runs cmd without $RAYLINE_PLATFORMS / $RAYLINE_SCENES, in
# WORK_DIR/elsewhere; fails the test on a non-zero exit, else stores stdout in OUT_VAR.
function(run name out_var)
  execute_process(COMMAND ${CMAKE_COMMAND} -E env --unset=RAYLINE_PLATFORMS --unset=RAYLINE_SCENES ${ARGN}
                  WORKING_DIRECTORY ${WORK_DIR}/elsewhere RESULT_VARIABLE rc OUTPUT_VARIABLE out ERROR_VARIABLE err)
  if(NOT rc EQUAL 0)
    message(FATAL_ERROR "${name} failed (${rc}):\n${ARGN}\n${out}\n${err}")
  endif()
  message(STATUS "${name}: ok")
  set(${out_var} "${out}" PARENT_SCOPE)
endfunction()

# check_json(FILE KEY EXPECTED): FILE's top-level string KEY equals EXPECTED.
function(check_json file key expected)
  file(READ ${file} text)
  string(JSON value GET "${text}" ${key})
  if(NOT value STREQUAL expected)
    message(FATAL_ERROR "${file}: ${key} is '${value}', expected '${expected}'")
  endif()
endfunction()

run("install" ignored ${CMAKE_COMMAND} --install ${BUILD_DIR} --prefix ${prefix})
foreach(f bin/rayline lib/cmake/Rayline/RaylineConfig.cmake include/rayline/sched/io/platform_loader.hpp
          share/rayline/platforms/paper-cluster.json share/rayline/scenes/museum.profile.json share/doc/rayline/LICENSE)
  if(NOT EXISTS ${prefix}/${f})
    message(FATAL_ERROR "not installed: ${prefix}/${f}")
  endif()
endforeach()

# The consumer: find_package(Rayline) and Rayline::sched, nothing else from the tree.
set(launcher "")
if(LAUNCHER)
  set(launcher -DCMAKE_CXX_COMPILER_LAUNCHER=${LAUNCHER})
endif()
run("configure consumer" ignored ${CMAKE_COMMAND} -S ${SOURCE_DIR}/tests/install/consumer -B ${WORK_DIR}/consumer
    -G ${GENERATOR} -DCMAKE_CXX_COMPILER=${CXX} "-DCMAKE_CXX_FLAGS=${CXX_FLAGS}" ${launcher} -DCMAKE_PREFIX_PATH=${prefix} -DCMAKE_BUILD_TYPE=Release)
run("build consumer" ignored ${CMAKE_COMMAND} --build ${WORK_DIR}/consumer)
run("run consumer" out ${WORK_DIR}/consumer/consumer)
if(NOT out MATCHES "platform paper-2A: 16 jobs, 16 E-jobs and [0-9]+ T-jobs, makespan [0-9.]+ s\n")
  message(FATAL_ERROR "unexpected consumer output: ${out}")
endif()
message(STATUS "${out}")

# The installed binary: its version, and its data found beside it.
run("rayline --version" version ${rayline} --version)
run("build tree's rayline --version" build_version ${BUILD_DIR}/apps/rayline --version)
if(NOT version STREQUAL build_version)
  message(FATAL_ERROR "installed version '${version}' differs from the build's '${build_version}'")
endif()
run("simulate" ignored ${rayline} simulate --duration 2s --no-progress --out ${WORK_DIR}/elsewhere/sim)
check_json(${WORK_DIR}/elsewhere/sim/metrics.json platform_file ${prefix}/share/rayline/platforms/paper-cluster.json)
run("simulate museum" ignored ${rayline} simulate --workload museum --duration 2s --no-progress --out museum)
check_json(${WORK_DIR}/elsewhere/museum/metrics.json workload ${prefix}/share/rayline/scenes/museum.profile.json)
# A platform that exists only in the installed folder.
file(COPY_FILE ${prefix}/share/rayline/platforms/paper-A.json ${prefix}/share/rayline/platforms/installed-only.json)
run("platform check installed-only" ignored ${rayline} platform check installed-only)

file(REMOVE_RECURSE ${WORK_DIR})  # passed: the prefix holds a copy of the binary, not kept
