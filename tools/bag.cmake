# dypho_bag (ROS: rosbag, sensor_msgs): RgbdFrames to/from TUM-style bags; dypho_dataset_to_bag;
# bag output for dypho_synth; unit tests. Built only with ROS (catkin).
if(NOT DYPHO_WITH_ROS)
  return()
endif()

add_library(dypho_bag
  ${CMAKE_CURRENT_SOURCE_DIR}/src/bag_conversions.cpp
  ${CMAKE_CURRENT_SOURCE_DIR}/src/bag_layout.cpp
  ${CMAKE_CURRENT_SOURCE_DIR}/src/bag_writer.cpp
  ${CMAKE_CURRENT_SOURCE_DIR}/src/bag_reader.cpp)
target_include_directories(dypho_bag PUBLIC $<BUILD_INTERFACE:${CMAKE_CURRENT_SOURCE_DIR}/include>)
target_include_directories(dypho_bag SYSTEM PRIVATE ${catkin_INCLUDE_DIRS})
target_link_libraries(dypho_bag PUBLIC dypho_common ${OpenCV_LIBS} PRIVATE dypho_ros_common ${catkin_LIBRARIES})
target_compile_features(dypho_bag PUBLIC cxx_std_17)
dypho_set_warnings(dypho_bag)
install(TARGETS dypho_bag ARCHIVE DESTINATION ${DYPHO_LIB_DEST} LIBRARY DESTINATION ${DYPHO_LIB_DEST})

# dypho_synth (from synth.cmake) also writes DIR/synthetic.bag when dypho_bag exists.
if(TARGET dypho_synth)
  target_link_libraries(dypho_synth PRIVATE dypho_bag)
  target_compile_definitions(dypho_synth PRIVATE DYPHO_SYNTH_WITH_BAG=1)
endif()

# dypho_dataset_to_bag needs the TUM reader and camera configs of dypho_tools (io.cmake).
if(TARGET dypho_tools)
  add_executable(dypho_dataset_to_bag ${CMAKE_CURRENT_SOURCE_DIR}/apps/dataset_to_bag_main.cpp)
  target_link_libraries(dypho_dataset_to_bag PRIVATE dypho_bag dypho_tools)
  dypho_set_warnings(dypho_dataset_to_bag)
  set_target_properties(dypho_dataset_to_bag PROPERTIES
    RUNTIME_OUTPUT_DIRECTORY ${CATKIN_DEVEL_PREFIX}/${CATKIN_PACKAGE_BIN_DESTINATION})
  install(TARGETS dypho_dataset_to_bag RUNTIME DESTINATION ${CATKIN_PACKAGE_BIN_DESTINATION})
endif()

if(EXISTS ${CMAKE_CURRENT_SOURCE_DIR}/test/test_bag_io.cpp)
  dypho_add_gtest(test_bag_io SOURCES ${CMAKE_CURRENT_SOURCE_DIR}/test/test_bag_io.cpp
    LIBS dypho_bag ${catkin_LIBRARIES})
  if(TARGET test_bag_io)
    target_include_directories(test_bag_io SYSTEM PRIVATE ${catkin_INCLUDE_DIRS})
  endif()
endif()

# graph_soak_probe (bench/): records a running graph for a soak (bench/graph_soak.sh).
add_executable(graph_soak_probe ${DYPHO_REAL_SOURCE_DIR}/bench/graph_soak_probe.cpp)
target_include_directories(graph_soak_probe SYSTEM PRIVATE ${catkin_INCLUDE_DIRS})
target_link_libraries(graph_soak_probe PRIVATE dypho_common ${catkin_LIBRARIES})
add_dependencies(graph_soak_probe ${PROJECT_NAME}_generate_messages_cpp)
dypho_set_warnings(graph_soak_probe)
set_target_properties(graph_soak_probe PROPERTIES
  RUNTIME_OUTPUT_DIRECTORY ${CATKIN_DEVEL_PREFIX}/${CATKIN_PACKAGE_BIN_DESTINATION})
