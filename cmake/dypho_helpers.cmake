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
    catkin_add_gtest(${name} ${ARG_SOURCES} TIMEOUT ${ARG_TIMEOUT}
      WORKING_DIRECTORY ${CMAKE_CURRENT_BINARY_DIR})
  else()
    add_executable(${name} ${ARG_SOURCES})
    target_link_libraries(${name} GTest::gtest_main)
    add_test(NAME ${name} COMMAND ${name})
    set_tests_properties(${name} PROPERTIES TIMEOUT ${ARG_TIMEOUT})
  endif()
  if(TARGET ${name})
    target_link_libraries(${name} ${ARG_LIBS})
    target_compile_definitions(${name} PRIVATE
      DYPHO_SOURCE_DIR="${DYPHO_REAL_SOURCE_DIR}"
      DYPHO_SHARED_DIR="${DYPHO_SHARED_DIR}")
    dypho_set_warnings(${name})
  endif()
endfunction()
