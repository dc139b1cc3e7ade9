# Helpers shared by the module CMakeLists.

# Warnings on, private to the target.
function(dypho_set_warnings target)
  target_compile_options(${target} PRIVATE
    $<$<COMPILE_LANGUAGE:CXX>:-Wall -Wextra -Wno-deprecated-copy>)
endfunction()

# dypho_add_gtest(<name> SOURCES <files...> LIBS <targets...> [TIMEOUT <s>])
# A gtest executable linking only core libraries; registered with catkin (run_tests) when
# catkin is used, with CTest otherwise. Tests get DYPHO_SOURCE_DIR and DYPHO_SHARED_DIR.
function(dypho_add_gtest name)
  cmake_parse_arguments(ARG "" "TIMEOUT" "SOURCES;LIBS" ${ARGN})
  if(NOT DYPHO_TESTING)
    return()
  endif()
  if(NOT ARG_TIMEOUT)
    set(ARG_TIMEOUT 300)
  endif()
  if(DYPHO_WITH_ROS)
    catkin_add_gtest(${name} ${ARG_SOURCES} WORKING_DIRECTORY ${CMAKE_CURRENT_BINARY_DIR})
    if(TEST _ctest_${PROJECT_NAME}_gtest_${name})
      set_tests_properties(_ctest_${PROJECT_NAME}_gtest_${name} PROPERTIES TIMEOUT ${ARG_TIMEOUT})
    endif()
  else()
    add_executable(${name} ${ARG_SOURCES})
    target_link_libraries(${name} GTest::gtest_main)
    add_test(NAME ${name} COMMAND ${name})
    set_tests_properties(${name} PROPERTIES TIMEOUT ${ARG_TIMEOUT})
  endif()
  if(TARGET ${name})
    target_link_libraries(${name} ${ARG_LIBS})
    if(DYPHO_WITH_ROS)  # catkin_add_gtest links gtest without main()
      if(TARGET GTest::gtest_main)
        target_link_libraries(${name} GTest::gtest_main)
      elseif(TARGET gtest_main)
        target_link_libraries(${name} gtest_main)
      endif()
    endif()
    target_compile_definitions(${name} PRIVATE
      DYPHO_SOURCE_DIR="${DYPHO_REAL_SOURCE_DIR}"
      DYPHO_SHARED_DIR="${DYPHO_SHARED_DIR}")
    dypho_set_warnings(${name})
  endif()
endfunction()

# dypho_add_nodelet(<module>): the thin ROS adapter library dypho_<module>_nodelet built from
# dypho_<module>/src/ros/*.cpp, linking the module's core.
function(dypho_add_nodelet module)
  if(NOT DYPHO_WITH_ROS)
    return()
  endif()
  file(GLOB _sources ${CMAKE_CURRENT_SOURCE_DIR}/src/ros/*.cpp)
  add_library(dypho_${module}_nodelet ${_sources})
  target_link_libraries(dypho_${module}_nodelet dypho_${module}_core dypho_ros_common ${ARGN})
  add_dependencies(dypho_${module}_nodelet ${PROJECT_NAME}_generate_messages_cpp)
  dypho_set_warnings(dypho_${module}_nodelet)
  install(TARGETS dypho_${module}_nodelet LIBRARY DESTINATION ${DYPHO_LIB_DEST})
endfunction()
