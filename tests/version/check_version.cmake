# version.* tests (tests/version/CMakeLists.txt).
#   MODE=binary: `rayline --version` prints "rayline <V>", V is `git describe --tags --always
#     --dirty` of the source tree when that is a git work tree, and simulate's metrics.json
#     records the same V.
#   MODE=script: cmake/RaylineVersion.cmake on scratch folders: the fallback outside git, a
#     bare commit, a tag, a commit after the tag, uncommitted changes.
#   cmake -DMODE=binary -DRAYLINE=... -DSOURCE_DIR=... -DWORK_DIR=... -P check_version.cmake
#   cmake -DMODE=script -DSOURCE_DIR=... -DWORK_DIR=... -P check_version.cmake
file(REMOVE_RECURSE ${WORK_DIR})
file(MAKE_DIRECTORY ${WORK_DIR})
find_program(GIT git)

# out_var <- stdout of the command, which must succeed.
function(run out_var)
  execute_process(COMMAND ${ARGN} WORKING_DIRECTORY ${WORK_DIR} RESULT_VARIABLE rc OUTPUT_VARIABLE out
                  ERROR_VARIABLE err OUTPUT_STRIP_TRAILING_WHITESPACE)
  if(NOT rc EQUAL 0)
    message(FATAL_ERROR "failed (${rc}): ${ARGN}\n${out}\n${err}")
  endif()
  set(${out_var} "${out}" PARENT_SCOPE)
endfunction()

# The version RaylineVersion.cmake writes for `dir` must match the regular expression `expected`.
function(expect_version dir expected)
  run(ignored ${CMAKE_COMMAND} -DSOURCE_DIR=${dir} -DOUTPUT=${WORK_DIR}/v.hpp -DFALLBACK=0.1.0
      -P ${SOURCE_DIR}/cmake/RaylineVersion.cmake)
  file(READ ${WORK_DIR}/v.hpp header)
  string(REGEX MATCH "#define RAYLINE_VERSION_STRING \"([^\"]*)\"" ignored "${header}")
  if(NOT CMAKE_MATCH_1 MATCHES "^${expected}$")
    message(FATAL_ERROR "${dir}: version '${CMAKE_MATCH_1}', expected /^${expected}$/")
  endif()
  message(STATUS "${dir}: ${CMAKE_MATCH_1}")
endfunction()

if(MODE STREQUAL "binary")
  run(printed ${RAYLINE} --version)
  if(NOT printed MATCHES "^rayline ([^ \n]+)$")
    message(FATAL_ERROR "--version printed '${printed}'")
  endif()
  set(version ${CMAKE_MATCH_1})
  if(GIT)
    execute_process(COMMAND ${GIT} -C ${SOURCE_DIR} rev-parse --show-toplevel RESULT_VARIABLE rc
                    OUTPUT_VARIABLE top OUTPUT_STRIP_TRAILING_WHITESPACE ERROR_QUIET)
    file(REAL_PATH ${SOURCE_DIR} source_real)
    if(rc EQUAL 0 AND top STREQUAL source_real)
      run(described ${GIT} -C ${SOURCE_DIR} describe --tags --always --dirty)
      if(NOT version STREQUAL described)
        message(FATAL_ERROR "--version says '${version}', git describe '${described}' (rebuild rayline?)")
      endif()
    endif()
  endif()
  run(ignored ${RAYLINE} simulate --duration 1s --no-progress --out ${WORK_DIR}/sim)
  file(READ ${WORK_DIR}/sim/metrics.json metrics)
  string(JSON recorded GET "${metrics}" rayline version)
  if(NOT recorded STREQUAL version)
    message(FATAL_ERROR "metrics.json records version '${recorded}', --version says '${version}'")
  endif()
  message(STATUS "rayline ${version}, recorded in metrics.json")
elseif(MODE STREQUAL "script")
  expect_version(${WORK_DIR} "0\\.1\\.0")  # not the top of a git work tree
  if(NOT GIT)
    return()
  endif()
  set(repo ${WORK_DIR}/repo)
  file(MAKE_DIRECTORY ${repo})
  set(git ${GIT} -C ${repo} -c user.name=rayline -c user.email=rayline@localhost -c commit.gpgsign=false
      -c tag.gpgsign=false)
  run(ignored ${git} init -q)
  file(WRITE ${repo}/a.txt "1\n")
  run(ignored ${git} add a.txt)
  run(ignored ${git} commit -q -m one)
  expect_version(${repo} "[0-9a-f]+")  # no tag yet: the abbreviated commit
  run(ignored ${git} tag -a v9.8.7 -m v9.8.7)
  expect_version(${repo} "v9\\.8\\.7")
  file(WRITE ${repo}/a.txt "2\n")
  expect_version(${repo} "v9\\.8\\.7-dirty")
  run(ignored ${git} commit -q -a -m two)
  expect_version(${repo} "v9\\.8\\.7-1-g[0-9a-f]+")
  file(MAKE_DIRECTORY ${repo}/unpacked)  # sources inside another repository: not theirs
  expect_version(${repo}/unpacked "0\\.1\\.0")
else()
  message(FATAL_ERROR "MODE must be binary or script")
endif()
