# dypho_synth_core: ROS-free synthetic RGB-D dynamic scene (ray-cast room + walking people) and
# its TUM-layout writer; dypho_synth: the command-line generator (bag output added by bag.cmake
# when dypho_bag is built); unit tests.
add_library(dypho_synth_core
  ${CMAKE_CURRENT_SOURCE_DIR}/src/synthetic_scene.cpp
  ${CMAKE_CURRENT_SOURCE_DIR}/src/synthetic_camera_effects.cpp
  ${CMAKE_CURRENT_SOURCE_DIR}/src/synthetic_geometry.cpp
  ${CMAKE_CURRENT_SOURCE_DIR}/src/synthetic_motion.cpp
  ${CMAKE_CURRENT_SOURCE_DIR}/src/synthetic_people.cpp
  ${CMAKE_CURRENT_SOURCE_DIR}/src/synthetic_people_starts.cpp
  ${CMAKE_CURRENT_SOURCE_DIR}/src/synthetic_texture.cpp
  ${CMAKE_CURRENT_SOURCE_DIR}/src/synthetic_writer.cpp)
target_include_directories(dypho_synth_core PUBLIC
  $<BUILD_INTERFACE:${CMAKE_CURRENT_SOURCE_DIR}/include>)
target_link_libraries(dypho_synth_core PUBLIC dypho_common Threads::Threads ${OpenCV_LIBS})
target_compile_features(dypho_synth_core PUBLIC cxx_std_17)
dypho_set_warnings(dypho_synth_core)
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
