# cmake -P script run by ctest: install, configure the consumer against the installed
# package only (no build tree on any search path), build it and run it.
foreach(var STOREY_BUILD_DIR CONSUMER_SOURCE_DIR WORK_DIR GENERATOR CXX_COMPILER STOREY_VERSION)
  if(NOT ${var})
    message(FATAL_ERROR "${var} is not set")
  endif()
endforeach()

function(run step)
  execute_process(COMMAND ${ARGN} RESULT_VARIABLE status OUTPUT_VARIABLE out ERROR_VARIABLE err)
  if(NOT status EQUAL 0)
    message(FATAL_ERROR "${step} failed (${status}):\n${out}\n${err}")
  endif()
  message(STATUS "${step}: ok")
  set(last_output "${out}" PARENT_SCOPE)
endfunction()

file(REMOVE_RECURSE ${WORK_DIR})
set(prefix ${WORK_DIR}/prefix)
run("install" ${CMAKE_COMMAND} --install ${STOREY_BUILD_DIR} --prefix ${prefix})
foreach(installed bin/storey lib/cmake/storey/storeyConfig.cmake
        lib/cmake/storey/storeyTargets.cmake include/storey/geometry/pose2.h
        include/storey/bag/bag_reader.h include/storey_messages/sensor_msgs/msg/LaserScan.h
        include/storey/common/shipped_config.h
        share/storey/config)
  if(NOT EXISTS ${prefix}/${installed})
    message(FATAL_ERROR "the install lacks ${installed}")
  endif()
endforeach()
run("configure consumer" ${CMAKE_COMMAND} -S ${CONSUMER_SOURCE_DIR} -B ${WORK_DIR}/build
    -G ${GENERATOR} -DCMAKE_CXX_COMPILER=${CXX_COMPILER} -DCMAKE_PREFIX_PATH=${prefix}
    -DCMAKE_FIND_USE_PACKAGE_REGISTRY=OFF -DSTOREY_VERSION=${STOREY_VERSION})
run("build consumer" ${CMAKE_COMMAND} --build ${WORK_DIR}/build)
run("run consumer" ${WORK_DIR}/build/storey_consumer ${WORK_DIR}/bag)
message(STATUS "${last_output}")
run("installed storey command" ${prefix}/bin/storey bag info ${WORK_DIR}/bag)
message(STATUS "${last_output}")
