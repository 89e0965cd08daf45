# Runs fastddsgen once over all message files (in dependency order) into WORK_DIR, then
# copies each file's own outputs to OUT_DIR/<pkg>/msg/. Called by idl/CMakeLists.txt.
file(REMOVE_RECURSE ${WORK_DIR})
file(MAKE_DIRECTORY ${WORK_DIR})
set(inputs "")
foreach(stem ${STEMS})
  list(APPEND inputs ${stem}.idl)
endforeach()
execute_process(
  COMMAND ${FASTDDSGEN} -cs -typeros2 -replace -d ${WORK_DIR} -I ${IDL_DIR} ${inputs}
  WORKING_DIRECTORY ${IDL_DIR}
  RESULT_VARIABLE result
  OUTPUT_VARIABLE output
  ERROR_VARIABLE output)
if(NOT result EQUAL 0 OR output MATCHES "ERROR")
  message(FATAL_ERROR "fastddsgen failed (${result}):\n${output}")
endif()
foreach(stem ${STEMS})
  get_filename_component(name ${stem} NAME)
  get_filename_component(dir ${stem} DIRECTORY)
  foreach(suffix .h .cxx PubSubTypes.h PubSubTypes.cxx)
    if(NOT EXISTS ${WORK_DIR}/${name}${suffix})
      message(FATAL_ERROR "fastddsgen did not write ${name}${suffix} for idl/${stem}.idl")
    endif()
    file(MAKE_DIRECTORY ${OUT_DIR}/${dir})
    file(COPY_FILE ${WORK_DIR}/${name}${suffix} ${OUT_DIR}/${dir}/${name}${suffix})
  endforeach()
endforeach()
