# dypho_synth_core: ROS-free synthetic RGB-D dynamic scene (ray-cast room + walking people) and
# its TUM-layout writer; dypho_synth: the command-line generator (bag output added by bag.cmake
# when dypho_bag is built); unit tests.
set(_dypho_synth_sources
  ${CMAKE_CURRENT_SOURCE_DIR}/src/synthetic_scene.cpp
  ${CMAKE_CURRENT_SOURCE_DIR}/src/synthetic_camera_effects.cpp
  ${CMAKE_CURRENT_SOURCE_DIR}/src/synthetic_geometry.cpp
  ${CMAKE_CURRENT_SOURCE_DIR}/src/synthetic_motion.cpp
  ${CMAKE_CURRENT_SOURCE_DIR}/src/synthetic_people.cpp
  ${CMAKE_CURRENT_SOURCE_DIR}/src/synthetic_people_starts.cpp
  ${CMAKE_CURRENT_SOURCE_DIR}/src/synthetic_texture.cpp
  ${CMAKE_CURRENT_SOURCE_DIR}/src/synthetic_writer.cpp)
function(dypho_add_synth_library name)
  add_library(${name} ${_dypho_synth_sources})
  target_include_directories(${name} PUBLIC $<BUILD_INTERFACE:${CMAKE_CURRENT_SOURCE_DIR}/include>)
  target_link_libraries(${name} PUBLIC dypho_common Threads::Threads ${OpenCV_LIBS})
  target_compile_features(${name} PUBLIC cxx_std_17)
  dypho_set_warnings(${name})
  target_compile_options(${name} PRIVATE ${ARGN})
endfunction()
dypho_add_synth_library(dypho_synth_core ${DYPHO_HOT_LOOP_COMPILE_OPTIONS})  # cmake/dypho_helpers.cmake
# dypho_synth_input: the generator as the other modules' tests link it to render their input
# frames. It is dypho_synth_core, unless DYPHO_SYNTH_INPUT_COMPILE_OPTIONS (cache list, default
# empty) is set: then a second build of the same sources with those options. Under the sanitizers
# (scripts/test_sanitized.sh: -O2 without them) rendering the inputs took 27-80 % of the
# pipeline and tracking tests' samples; the code under test keeps every check, and the generator's
# own tests (test_synthetic_*) keep the sanitized dypho_synth_core.
add_library(dypho_synth_input INTERFACE)
if(DYPHO_SYNTH_INPUT_COMPILE_OPTIONS)
  dypho_add_synth_library(dypho_synth_input_build ${DYPHO_SYNTH_INPUT_COMPILE_OPTIONS})
  target_link_libraries(dypho_synth_input INTERFACE dypho_synth_input_build)
else()
  target_link_libraries(dypho_synth_input INTERFACE dypho_synth_core)
endif()
install(TARGETS dypho_synth_core
  ARCHIVE DESTINATION ${DYPHO_LIB_DEST} LIBRARY DESTINATION ${DYPHO_LIB_DEST})

add_executable(dypho_synth ${CMAKE_CURRENT_SOURCE_DIR}/apps/synth_main.cpp)
target_link_libraries(dypho_synth PRIVATE dypho_synth_core)
dypho_set_warnings(dypho_synth)
if(DYPHO_WITH_ROS)
  # rosrun dypho_slam dypho_synth: devel/lib/dypho_slam and lib/dypho_slam when installed.
  set_target_properties(dypho_synth PROPERTIES
    RUNTIME_OUTPUT_DIRECTORY ${CATKIN_DEVEL_PREFIX}/${CATKIN_PACKAGE_BIN_DESTINATION})
  install(TARGETS dypho_synth RUNTIME DESTINATION ${CATKIN_PACKAGE_BIN_DESTINATION})
else()
  install(TARGETS dypho_synth RUNTIME DESTINATION ${DYPHO_BIN_DEST})
endif()

set(_dypho_synth_test_libs dypho_synth_core)
set(_dypho_synth_test_defs "")
if(TARGET dypho_tools)
  list(APPEND _dypho_synth_test_libs dypho_tools)
  set(_dypho_synth_test_defs DYPHO_HAVE_TOOLS_IO=1)
endif()
foreach(_t test_synthetic_scene test_synthetic_motion test_synthetic_writer test_synthetic_people
    test_synthetic_camera_effects)
  if(EXISTS ${CMAKE_CURRENT_SOURCE_DIR}/test/${_t}.cpp)
    dypho_add_gtest(${_t} SOURCES ${CMAKE_CURRENT_SOURCE_DIR}/test/${_t}.cpp
      LIBS ${_dypho_synth_test_libs} ${OpenCV_LIBS})
    if(TARGET ${_t} AND _dypho_synth_test_defs)
      target_compile_definitions(${_t} PRIVATE ${_dypho_synth_test_defs})
    endif()
  endif()
endforeach()
if(TARGET test_synthetic_people)
  # Checks the people's paths directly: the private header synthetic_internal.h.
  target_include_directories(test_synthetic_people PRIVATE ${CMAKE_CURRENT_SOURCE_DIR}/src)
endif()
