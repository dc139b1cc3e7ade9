# dypho_tools (ROS-free): camera configs, TUM/Bonn dataset reader, trajectory I/O, ATE/RPE
# evaluation and trajectory plots; plus the dypho_evaluate command-line tool and unit tests.
# Included from tools/CMakeLists.txt, so CMAKE_CURRENT_SOURCE_DIR is tools/.

get_filename_component(DYPHO_TOOLS_SOURCE_CONFIG_DIR "${CMAKE_CURRENT_SOURCE_DIR}/../config" ABSOLUTE)
if(IS_ABSOLUTE "${DYPHO_SHARE_DEST}")
  set(DYPHO_TOOLS_INSTALL_CONFIG_DIR "${DYPHO_SHARE_DEST}/config")
else()
  set(DYPHO_TOOLS_INSTALL_CONFIG_DIR "${CMAKE_INSTALL_PREFIX}/${DYPHO_SHARE_DEST}/config")
endif()

find_package(yaml-cpp REQUIRED)  # target yaml-cpp (Debian libyaml-cpp-dev)

add_library(dypho_tools
  ${CMAKE_CURRENT_SOURCE_DIR}/src/camera_config.cpp
  ${CMAKE_CURRENT_SOURCE_DIR}/src/tum_dataset.cpp
  ${CMAKE_CURRENT_SOURCE_DIR}/src/evaluation.cpp
  ${CMAKE_CURRENT_SOURCE_DIR}/src/trajectory_plot.cpp)
add_library(dypho::tools ALIAS dypho_tools)
target_include_directories(dypho_tools PUBLIC
  $<BUILD_INTERFACE:${CMAKE_CURRENT_SOURCE_DIR}/include>
  $<INSTALL_INTERFACE:include>)
target_link_libraries(dypho_tools
  PUBLIC dypho_common dypho_trajectory_io Eigen3::Eigen ${OpenCV_LIBS}
  PRIVATE yaml-cpp)
target_compile_features(dypho_tools PUBLIC cxx_std_17)
target_compile_definitions(dypho_tools PRIVATE
  DYPHO_TOOLS_SOURCE_CONFIG_DIR="${DYPHO_TOOLS_SOURCE_CONFIG_DIR}"
  DYPHO_TOOLS_INSTALL_CONFIG_DIR="${DYPHO_TOOLS_INSTALL_CONFIG_DIR}")
dypho_set_warnings(dypho_tools)
install(TARGETS dypho_tools
  ARCHIVE DESTINATION ${DYPHO_LIB_DEST}
  LIBRARY DESTINATION ${DYPHO_LIB_DEST}
  RUNTIME DESTINATION ${DYPHO_BIN_DEST})

# dypho_evaluate: ATE/RPE of a TUM trajectory (with catkin it lands in devel/lib/dypho_slam, rosrun-able).
add_executable(dypho_evaluate ${CMAKE_CURRENT_SOURCE_DIR}/apps/evaluate_main.cpp)
target_link_libraries(dypho_evaluate PRIVATE dypho_tools)
dypho_set_warnings(dypho_evaluate)
if(DYPHO_WITH_ROS)
  install(TARGETS dypho_evaluate RUNTIME DESTINATION ${CATKIN_PACKAGE_BIN_DESTINATION})
else()
  install(TARGETS dypho_evaluate RUNTIME DESTINATION ${DYPHO_BIN_DEST})
endif()

# catkin_add_gtest links gtest without its main(): take main() from GTest::gtest_main (defined by
# CMake's FindGTest or catkin's gtest.cmake; the plain-CMake path links it already).
set(_dypho_tools_io_gtest_main "")
if(TARGET GTest::gtest_main)
  set(_dypho_tools_io_gtest_main GTest::gtest_main)
endif()
dypho_add_gtest(test_dypho_tools_io
  SOURCES ${CMAKE_CURRENT_SOURCE_DIR}/test/test_camera_config.cpp
          ${CMAKE_CURRENT_SOURCE_DIR}/test/test_tum_dataset.cpp
          ${CMAKE_CURRENT_SOURCE_DIR}/test/test_evaluation.cpp
          ${CMAKE_CURRENT_SOURCE_DIR}/test/test_trajectory_plot.cpp
  LIBS dypho_tools ${_dypho_tools_io_gtest_main})
if(TARGET test_dypho_tools_io)
  # test_trajectory_plot.cpp checks the plot's layout steps: the private trajectory_plot_layout.h.
  target_include_directories(test_dypho_tools_io PRIVATE ${CMAKE_CURRENT_SOURCE_DIR}/src)
endif()
