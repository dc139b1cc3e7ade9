# Helpers shared by the module CMakeLists.

# Warnings on, private to the target.
function(dypho_set_warnings target)
  target_compile_options(${target} PRIVATE
    $<$<COMPILE_LANGUAGE:CXX>:-Wall -Wextra -Wno-deprecated-copy>)
endfunction()

# dypho_add_gtest(<name> SOURCES <files...> LIBS <targets...> [TIMEOUT <s>] [COST <s>] [SHARDS <n>] [WHOLE_SYSTEM]
#                 [ALL_CORES])
# A gtest executable linking only core libraries, registered with CTest through
# scripts/run_gtest.sh: a test that skips itself (GTEST_SKIP) makes ctest report the executable as
# skipped (SKIP_RETURN_CODE 77), never as passed; a failure is still a failure. With catkin the
# executable is built by the `tests` target. Tests get DYPHO_SOURCE_DIR and DYPHO_SHARED_DIR.
# COST: about how long the test runs (seconds, ASan build, 2 cores); `ctest -j` starts the
# costliest first on a build with no timing history, so the long tests do not end up last.
# WHOLE_SYSTEM: runs the tools on whole sequences; not part of `unit_tests` (plain CMake builds).
# SHARDS <n>: the executable runs as n gtest shards side by side (scripts/run_gtest.sh --shards),
# for whole-system tests whose runs keep about one core each busy while `ctest -j 1` runs the
# suite (test_datasets: 142 % CPU on 2 cores as one process).
# DYPHO_TEST_COMPILE_OPTIONS (cache list, default empty): extra compile options of the test
# executables' own files only, not of the libraries they test (scripts/test_sanitized.sh compiles
# the test files without UBSan: -fno-sanitize=undefined).
# DYPHO_HOT_LOOP_COMPILE_OPTIONS (cache list, default empty): extra compile options of the code
# whose loops take most of the tests' time, the rasterizer's tile kernels and the synthetic
# generator's ray caster (scripts/test_sanitized.sh compiles them at -O2 under the sanitizers,
# which keep all their checks there).
# Every test made here is labelled `unit` (ctest -L unit), or `whole_system` with WHOLE_SYSTEM:
# scripts/test.sh runs the unit tests two at a time and the rest (rostests, launch and dataset
# runs, which play at real time or keep both cores busy) one at a time.
# ALL_CORES: the test keeps several threads busy; `ctest -j` never runs two such tests at once
# (under ASan on 2 cores the mapper and pipeline tests took 521 and 439 s side by side; 329 s
# beside a single-threaded test and 254 s alone).
function(dypho_add_gtest name)
  cmake_parse_arguments(ARG "WHOLE_SYSTEM;ALL_CORES" "TIMEOUT;COST;SHARDS" "SOURCES;LIBS" ${ARGN})
  if(NOT DYPHO_TESTING)
    return()
  endif()
  if(NOT ARG_TIMEOUT)
    set(ARG_TIMEOUT 300)
  endif()
  # Instrumented builds (ASan + UBSan, scripts/test_sanitized.sh) run several times slower: their
  # wall-clock limits scale with DYPHO_TEST_TIMEOUT_SCALE; the assertions do not change.
  if(DYPHO_TEST_TIMEOUT_SCALE)
    math(EXPR ARG_TIMEOUT "${ARG_TIMEOUT} * ${DYPHO_TEST_TIMEOUT_SCALE}")
  endif()
  if(DYPHO_WITH_ROS)
    dypho_add_test_executable(${name} ${ARG_SOURCES})
  else()
    add_executable(${name} ${ARG_SOURCES})
    target_link_libraries(${name} GTest::gtest_main)
  endif()
  if(NOT TARGET ${name})
    return()
  endif()
  if(TARGET unit_tests AND NOT ARG_WHOLE_SYSTEM)
    add_dependencies(unit_tests ${name})
  endif()
  if(NOT ARG_SHARDS)
    set(ARG_SHARDS 1)
  endif()
  add_test(NAME ${name} COMMAND bash ${DYPHO_REAL_SOURCE_DIR}/scripts/run_gtest.sh --shards ${ARG_SHARDS} $<TARGET_FILE:${name}>
           WORKING_DIRECTORY ${CMAKE_CURRENT_BINARY_DIR})
  set_tests_properties(${name} PROPERTIES TIMEOUT ${ARG_TIMEOUT} SKIP_RETURN_CODE 77)
  if(ARG_WHOLE_SYSTEM)
    set_tests_properties(${name} PROPERTIES LABELS whole_system)
  else()
    set_tests_properties(${name} PROPERTIES LABELS unit)
  endif()
  if(ARG_COST)
    set_tests_properties(${name} PROPERTIES COST ${ARG_COST})
  endif()
  if(ARG_ALL_CORES)
    set_tests_properties(${name} PROPERTIES RESOURCE_LOCK dypho_all_cores)
  endif()
  target_link_libraries(${name} ${ARG_LIBS})
  # DYPHO_UNITY_TESTS: the test files compiled eight at a time. Each file's helpers live in
  # `namespace DYPHO_UNITY_ID`: a name of its own in a unity batch, anonymous otherwise.
  list(LENGTH ARG_SOURCES _files)
  if(DYPHO_UNITY_TESTS AND _files GREATER 1)
    set_target_properties(${name} PROPERTIES UNITY_BUILD ON UNITY_BUILD_BATCH_SIZE 8 UNITY_BUILD_UNIQUE_ID DYPHO_UNITY_ID)
  else()
    target_compile_definitions(${name} PRIVATE DYPHO_UNITY_ID=)
  endif()
  if(DYPHO_WITH_ROS)  # catkin's gtest target links gtest without main()
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
  target_compile_options(${name} PRIVATE ${DYPHO_TEST_COMPILE_OPTIONS})
endfunction()

# dypho_add_test_executable(<name> <sources...>): a gtest executable (catkin, gtest linked) that is
# built by the `tests` target only. catkin_add_executable_with_gtest() puts it into `all`, so
# `catkin_make` and a plain build compiled every test a user never runs.
function(dypho_add_test_executable name)
  catkin_add_executable_with_gtest(${name} ${ARGN})
  if(TARGET ${name})
    set_target_properties(${name} PROPERTIES EXCLUDE_FROM_ALL ON)
    target_compile_definitions(${name} PRIVATE DYPHO_UNITY_ID=)  # one file: anonymous (dypho_add_gtest)
    add_dependencies(tests ${name})
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

# dypho_add_rostest(<name> FILE <file.test> [ARGS <arg:=value>...] [DEPENDENCIES <targets>...])
# A rostest registered under a name we choose (ctest: _ctest_dypho_slam_rostest_<name>; catkin:
# run_tests_dypho_slam_rostest_<name>). catkin's add_rostest() builds the target name from the
# file and every argument, so an absolute path in ARGS puts the build folder's path into file
# names three times and a clone under a home folder exceeds the 255-character file name limit.
# Each word of the command is shell-quoted, so paths with spaces stay one argument each.
function(dypho_add_rostest name)
  cmake_parse_arguments(ARG "" "FILE" "ARGS;DEPENDENCIES" ${ARGN})
  if(NOT DYPHO_TESTING OR NOT DYPHO_WITH_ROS)
    return()
  endif()
  get_filename_component(_file "${ARG_FILE}" ABSOLUTE BASE_DIR "${CMAKE_CURRENT_SOURCE_DIR}")
  if(NOT EXISTS "${_file}")
    message(FATAL_ERROR "dypho_add_rostest(${name}): no rostest file ${_file}")
  endif()
  find_program(DYPHO_ROSTEST_EXE rostest PATHS /usr/bin /opt/ros/noetic/bin NO_CMAKE_PATH)
  if(NOT DYPHO_ROSTEST_EXE)
    message(FATAL_ERROR "dypho_add_rostest: rostest not found (Debian: python3-rostest)")
  endif()
  # catkin's run_tests.py runs its command through a shell: one string, each word quoted.
  set(_command "")
  foreach(_word ${PYTHON_EXECUTABLE} ${DYPHO_ROSTEST_EXE} --pkgdir=${PROJECT_SOURCE_DIR}
                --package=${PROJECT_NAME} --results-filename ${name}.xml
                --results-base-dir ${CATKIN_TEST_RESULTS_DIR} ${_file} ${ARG_ARGS})
    string(REPLACE "'" "'\\''" _word "${_word}")
    string(APPEND _command " '${_word}'")
  endforeach()
  string(STRIP "${_command}" _command)
  catkin_run_tests_target("rostest" ${name} "rostest-${name}.xml" COMMAND "${_command}"
    DEPENDENCIES ${ARG_DEPENDENCIES})
endfunction()

# dypho_add_core_library(<module> SOURCES <files...> LIBS <public libraries...>)
# A module's ROS-free core: the library dypho_<module>_core (alias dypho::<module>_core) with the
# module's include/ folder, C++17, the project's warnings, installed.
function(dypho_add_core_library module)
  cmake_parse_arguments(ARG "" "" "SOURCES;LIBS" ${ARGN})
  set(_name dypho_${module}_core)
  add_library(${_name} ${ARG_SOURCES})
  add_library(dypho::${module}_core ALIAS ${_name})
  target_include_directories(${_name} PUBLIC
    $<BUILD_INTERFACE:${CMAKE_CURRENT_SOURCE_DIR}/include>
    $<INSTALL_INTERFACE:include>)
  target_link_libraries(${_name} PUBLIC ${ARG_LIBS})
  target_compile_features(${_name} PUBLIC cxx_std_17)
  dypho_set_warnings(${_name})
  install(TARGETS ${_name}
    ARCHIVE DESTINATION ${DYPHO_LIB_DEST}
    LIBRARY DESTINATION ${DYPHO_LIB_DEST}
    RUNTIME DESTINATION ${DYPHO_BIN_DEST})
endfunction()
