# What a plain CMake project that uses the core goes through: install the core-only build into a fresh
# prefix, build examples/ against it with find_package(mac_registration), and run the example on the
# shipped real correspondence set, after checking that the installed headers include only installed
# ones. Run by ctest in the core-only build:
#   cmake -DBUILD_DIR=... -DSOURCE_DIR=... -DWORK_DIR=... -P build_consumer.cmake
function(run what)
  execute_process(COMMAND ${ARGN} RESULT_VARIABLE rc OUTPUT_VARIABLE out ERROR_VARIABLE err)
  if(NOT rc EQUAL 0)
    message(FATAL_ERROR "${what} failed (${rc}):\n${out}\n${err}")
  endif()
  set(output "${out}" PARENT_SCOPE)
endfunction()

file(REMOVE_RECURSE ${WORK_DIR})
run("install" ${CMAKE_COMMAND} --install ${BUILD_DIR} --prefix ${WORK_DIR}/prefix)

# check_self_contained(ROOT): every quoted include of a header under ROOT names a header under ROOT. The
# private stages live in src/core and are not installed; an installed header that includes one breaks
# every user. Checked on this install, and on include/ whole, which the catkin build installs.
function(check_self_contained root)
  file(GLOB_RECURSE headers RELATIVE ${root} ${root}/*.hpp)
  if(NOT headers)
    message(FATAL_ERROR "no headers under ${root}")
  endif()
  foreach(header ${headers})
    file(STRINGS ${root}/${header} includes REGEX "^#include \"")
    foreach(line ${includes})
      string(REGEX REPLACE "^#include \"([^\"]+)\".*" "\\1" included "${line}")
      if(NOT EXISTS ${root}/${included})
        message(FATAL_ERROR "${root}/${header} includes ${included}, which is not beside it under ${root}")
      endif()
    endforeach()
  endforeach()
endfunction()
check_self_contained(${WORK_DIR}/prefix/include)
check_self_contained(${SOURCE_DIR}/include)
run("configure" ${CMAKE_COMMAND} -S ${SOURCE_DIR}/examples -B ${WORK_DIR}/build
  -DCMAKE_PREFIX_PATH=${WORK_DIR}/prefix -DCMAKE_BUILD_TYPE=Release)
run("build" ${CMAKE_COMMAND} --build ${WORK_DIR}/build)
run("the example" ${WORK_DIR}/build/register_correspondences
  ${SOURCE_DIR}/test/data/redkitchen_24_59/correspondences.txt ${SOURCE_DIR}/config/indoor_rgbd.yaml)
if(NOT output MATCHES "inliers of 5678 correspondences")
  message(FATAL_ERROR "unexpected output of the example:\n${output}")
endif()
message(STATUS "${output}")
