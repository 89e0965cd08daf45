# storey_core_library(NAME <area> [DEPS <targets>...] [PRIVATE_DEPS <targets>...])
# Builds every .cpp beside the calling CMakeLists.txt into storey_<area>
# (alias storey::<area>). Headers are included as "storey/<area>/x.h".
function(storey_core_library)
  cmake_parse_arguments(ARG "" "NAME" "DEPS;PRIVATE_DEPS" ${ARGN})
  file(GLOB sources CONFIGURE_DEPENDS ${CMAKE_CURRENT_SOURCE_DIR}/*.cpp)
  set(target storey_${ARG_NAME})
  if(NOT sources)
    # An area being started has a CMakeLists.txt before its first source file.
    message(STATUS "storey: area '${ARG_NAME}' has no sources yet; not built")
    return()
  endif()
  add_library(${target} STATIC ${sources})
  add_library(storey::${ARG_NAME} ALIAS ${target})
  target_include_directories(${target} PUBLIC
    $<BUILD_INTERFACE:${PROJECT_SOURCE_DIR}/components/core>
    $<BUILD_INTERFACE:${STOREY_GENERATED_INCLUDE}>
    $<INSTALL_INTERFACE:${CMAKE_INSTALL_INCLUDEDIR}>)
  target_link_libraries(${target} PUBLIC ${ARG_DEPS} PRIVATE ${ARG_PRIVATE_DEPS})
  add_dependencies(${target} storey_shipped_config)
  set_target_properties(${target} PROPERTIES EXPORT_NAME ${ARG_NAME})
  set_property(GLOBAL APPEND PROPERTY STOREY_LIBRARIES ${target})
  install(TARGETS ${target} EXPORT storeyTargets
    ARCHIVE DESTINATION ${CMAKE_INSTALL_LIBDIR}
    LIBRARY DESTINATION ${CMAKE_INSTALL_LIBDIR})
endfunction()

# storey_test(NAME <name> LABEL unit|integration|scenario LIBS <targets>...
#             [SOURCES <files>...])
# One gtest executable per call; every TEST becomes its own ctest entry with the label.
# Without SOURCES, every *_test.cpp beside the calling CMakeLists.txt is used; for a unit
# executable, its *_scenario_test.cpp files (whole synthetic runs that take seconds) go to a
# second executable (unit_X_tests: synthetic_X_tests) labelled scenario. Tests that name the same
# RESOURCE_LOCK never run at the same time (ctest --parallel).
function(storey_test)
  cmake_parse_arguments(ARG "" "NAME;LABEL;TIMEOUT;RESOURCE_LOCK" "LIBS;SOURCES" ${ARGN})
  if(NOT ARG_SOURCES)
    file(GLOB ARG_SOURCES CONFIGURE_DEPENDS ${CMAKE_CURRENT_SOURCE_DIR}/*_test.cpp)
    if(ARG_LABEL STREQUAL "unit")
      file(GLOB slow CONFIGURE_DEPENDS ${CMAKE_CURRENT_SOURCE_DIR}/*_scenario_test.cpp)
      if(slow)
        list(REMOVE_ITEM ARG_SOURCES ${slow})
        string(REGEX REPLACE "^unit_" "synthetic_" slow_name ${ARG_NAME})
        storey_test(NAME ${slow_name} LABEL scenario LIBS ${ARG_LIBS} SOURCES ${slow})
      endif()
    endif()
  endif()
  if(NOT ARG_TIMEOUT)
    set(ARG_TIMEOUT 300)
  endif()
  if(STOREY_SANITIZE)
    # Instrumented code at -O1 runs the numeric tests several times slower.
    math(EXPR ARG_TIMEOUT "${ARG_TIMEOUT} * 4")
  endif()
  if(NOT ARG_SOURCES)
    message(STATUS "storey: test '${ARG_NAME}' has no sources yet; not built")
    return()
  endif()
  add_executable(${ARG_NAME} ${ARG_SOURCES})
  target_link_libraries(${ARG_NAME} PRIVATE ${ARG_LIBS} storey_test_support GTest::gtest_main)
  target_compile_definitions(${ARG_NAME} PRIVATE STOREY_SOURCE_DIR="${PROJECT_SOURCE_DIR}")
  set(extra_properties)
  if(ARG_RESOURCE_LOCK)
    set(extra_properties RESOURCE_LOCK ${ARG_RESOURCE_LOCK})
  endif()
  gtest_discover_tests(${ARG_NAME}
    DISCOVERY_MODE PRE_TEST
    WORKING_DIRECTORY ${CMAKE_CURRENT_BINARY_DIR}
    PROPERTIES LABELS ${ARG_LABEL} TIMEOUT ${ARG_TIMEOUT} ${extra_properties})
endfunction()

# storey_component_library(NAME <component> DEPS <targets>...)
# A thin component: every .cpp under storey/<component>/ beside the calling CMakeLists.txt
# into storey_<component> (alias storey::<component>), linked into the catalog and the
# storey command through STOREY_LIBRARIES, and installed.
function(storey_component_library)
  cmake_parse_arguments(ARG "" "NAME" "DEPS" ${ARGN})
  file(GLOB sources CONFIGURE_DEPENDS ${CMAKE_CURRENT_SOURCE_DIR}/storey/${ARG_NAME}/*.cpp)
  set(target storey_${ARG_NAME})
  add_library(${target} STATIC ${sources})
  add_library(storey::${ARG_NAME} ALIAS ${target})
  target_include_directories(${target} PUBLIC
    $<BUILD_INTERFACE:${CMAKE_CURRENT_SOURCE_DIR}>
    $<INSTALL_INTERFACE:${CMAKE_INSTALL_INCLUDEDIR}>)
  target_link_libraries(${target} PUBLIC storey::runtime ${ARG_DEPS})
  set_target_properties(${target} PROPERTIES EXPORT_NAME ${ARG_NAME})
  set_property(GLOBAL APPEND PROPERTY STOREY_LIBRARIES ${target})
  install(TARGETS ${target} EXPORT storeyTargets
    ARCHIVE DESTINATION ${CMAKE_INSTALL_LIBDIR}
    LIBRARY DESTINATION ${CMAKE_INSTALL_LIBDIR})
  install(DIRECTORY storey DESTINATION ${CMAKE_INSTALL_INCLUDEDIR} FILES_MATCHING PATTERN "*.h")
endfunction()
