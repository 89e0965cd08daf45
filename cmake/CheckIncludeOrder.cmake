# Fails when a core module includes or links a module that does not come before it in the
# pipeline order (docs/architecture.md, "Modules"), or when a component includes a test bed.
# Run by ctest as IncludeOrder.* (label unit):
#   cmake -DSOURCE_DIR=<storey> [-DCHECK=core|components] -P cmake/CheckIncludeOrder.cmake
#
# A module may include only modules of a lower level. Modules on one level do not include
# each other: the floor detector, the floor mapper and the floor matcher exchange the data
# types of `floor`, not each other's code.
cmake_minimum_required(VERSION 3.22)

# One entry a level, lowest first; modules of one level separated by '|'.
set(storey_levels
  common
  geometry
  sensor
  "grid|graph"
  floor
  localization
  "detection|mapping|matching"
  building
  "io|bag"  # readers of outside formats: for the tools, the simulator and evaluation
  sim       # test beds: no component links them
  eval)

# Includes and links against the order that stay until the files that make them are
# changed: "<path from SOURCE_DIR>:<module included>" and "<module>:<module linked>".
set(storey_allowed)

# Modules a component (components/<name>, above core) must not include: the shipped
# components run on robots and servers and carry no simulator, log reader or evaluation.
set(storey_not_in_components sim eval)

if(NOT SOURCE_DIR)
  message(FATAL_ERROR "CheckIncludeOrder: give -DSOURCE_DIR=<storey source folder>")
endif()
if(NOT CHECK)
  set(CHECK core)
endif()

set(level 0)
foreach(entry IN LISTS storey_levels)
  math(EXPR level "${level} + 1")
  string(REPLACE "|" ";" names "${entry}")
  foreach(name IN LISTS names)
    set(level_of_${name} ${level})
  endforeach()
endforeach()

set(problems)
set(used_allowances)
set(core ${SOURCE_DIR}/components/core/storey)

if(CHECK STREQUAL "core")
  file(GLOB dirs LIST_DIRECTORIES true RELATIVE ${core} ${core}/*)
  foreach(module IN LISTS dirs)
    if(NOT IS_DIRECTORY ${core}/${module})
      continue()
    endif()
    if(NOT DEFINED level_of_${module})
      list(APPEND problems "components/core/storey/${module}: a module missing from the order in cmake/CheckIncludeOrder.cmake and docs/architecture.md")
      continue()
    endif()
    # Includes.
    file(GLOB_RECURSE files ${core}/${module}/*.h ${core}/${module}/*.cpp)
    foreach(file IN LISTS files)
      file(RELATIVE_PATH rel ${SOURCE_DIR} ${file})
      file(STRINGS ${file} lines REGEX "^[ \t]*#[ \t]*include[ \t]+\"storey/[a-z_]+/")
      foreach(line IN LISTS lines)
        string(REGEX REPLACE ".*\"storey/([a-z_]+)/.*" "\\1" included "${line}")
        if(included STREQUAL module)
          continue()
        endif()
        if("${rel}:${included}" IN_LIST storey_allowed)
          list(APPEND used_allowances "${rel}:${included}")
          continue()
        endif()
        if(NOT DEFINED level_of_${included})
          list(APPEND problems "${rel}: includes storey/${included}/, which is not a core module")
        elseif(NOT level_of_${included} LESS level_of_${module})
          list(APPEND problems "${rel}: ${module} (level ${level_of_${module}}) includes ${included} (level ${level_of_${included}})")
        endif()
      endforeach()
    endforeach()
    # Links.
    if(EXISTS ${core}/${module}/CMakeLists.txt)
      file(READ ${core}/${module}/CMakeLists.txt text)
      string(REGEX MATCHALL "storey::[a-z_]+" linked "${text}")
      list(REMOVE_DUPLICATES linked)
      foreach(target IN LISTS linked)
        string(REPLACE "storey::" "" dep "${target}")
        if(dep STREQUAL module)
          continue()
        endif()
        if("${module}:${dep}" IN_LIST storey_allowed)
          list(APPEND used_allowances "${module}:${dep}")
          continue()
        endif()
        if(NOT DEFINED level_of_${dep})
          list(APPEND problems "components/core/storey/${module}/CMakeLists.txt: links ${target}, which is not a core module")
        elseif(NOT level_of_${dep} LESS level_of_${module})
          list(APPEND problems "components/core/storey/${module}/CMakeLists.txt: ${module} (level ${level_of_${module}}) links ${target} (level ${level_of_${dep}})")
        endif()
      endforeach()
    endif()
  endforeach()
  # An allowance nothing needs any more is taken out, so the order cannot slip back.
  foreach(allowed IN LISTS storey_allowed)
    if(NOT allowed IN_LIST used_allowances)
      list(APPEND problems "${allowed}: no longer needed, remove it from storey_allowed in cmake/CheckIncludeOrder.cmake")
    endif()
  endforeach()
elseif(CHECK STREQUAL "components")
  file(GLOB dirs LIST_DIRECTORIES true ${SOURCE_DIR}/components/*)
  foreach(dir IN LISTS dirs)
    get_filename_component(name ${dir} NAME)
    if(name STREQUAL "core" OR NOT IS_DIRECTORY ${dir})
      continue()
    endif()
    file(GLOB_RECURSE files ${dir}/*.h ${dir}/*.cpp ${dir}/CMakeLists.txt)
    foreach(file IN LISTS files)
      file(RELATIVE_PATH rel ${SOURCE_DIR} ${file})
      file(STRINGS ${file} lines REGEX "storey/[a-z_]+/|storey::[a-z_]+")
      foreach(line IN LISTS lines)
        foreach(banned IN LISTS storey_not_in_components)
          if(line MATCHES "\"storey/${banned}/" OR line MATCHES "storey::${banned}([^a-z_]|$)")
            list(APPEND problems "${rel}: component code uses ${banned}: ${line}")
          endif()
        endforeach()
      endforeach()
    endforeach()
  endforeach()
else()
  message(FATAL_ERROR "CheckIncludeOrder: CHECK is core or components, not '${CHECK}'")
endif()

if(problems)
  list(LENGTH problems n)
  string(REPLACE ";" "\n  " text "${problems}")
  message(FATAL_ERROR "${n} against the module order (docs/architecture.md):\n  ${text}")
endif()
message(STATUS "CheckIncludeOrder (${CHECK}): every include and link follows the module order")
