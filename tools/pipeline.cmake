# dypho_frame_source: frames of a TUM-layout folder or a bag; dypho_run_dataset: the command users
# run (the in-process pipeline, dypho_pipeline, on a dataset).
if(TARGET dypho_tools AND TARGET dypho_mask_core AND TARGET dypho_tracking_core AND TARGET dypho_mapping_core)
  set(_frame_source_impl src/frame_source_nobag.cpp)
  if(TARGET dypho_bag)
    set(_frame_source_impl src/frame_source_bag.cpp)
  endif()
  add_library(dypho_frame_source
    src/frame_source.cpp
    ${_frame_source_impl})
  target_include_directories(dypho_frame_source PUBLIC
    $<BUILD_INTERFACE:${CMAKE_CURRENT_SOURCE_DIR}/include>)
  target_link_libraries(dypho_frame_source PUBLIC dypho_tools)
  if(TARGET dypho_bag)
    target_link_libraries(dypho_frame_source PUBLIC dypho_bag)
  endif()
  dypho_set_warnings(dypho_frame_source)

  # dypho_map_views: a saved map scored at every Nth frame of a sequence (the runner and
  # dypho_evaluate_map).
  add_library(dypho_map_views src/map_views.cpp)
  target_link_libraries(dypho_map_views PUBLIC dypho_frame_source dypho_mapping_core)
  dypho_set_warnings(dypho_map_views)

  add_executable(dypho_run_dataset apps/run_dataset_main.cpp apps/run_dataset_args.cpp)
  target_link_libraries(dypho_run_dataset dypho_pipeline dypho_frame_source dypho_map_views)
  dypho_set_warnings(dypho_run_dataset)
  add_executable(dypho_evaluate_map apps/evaluate_map_main.cpp)
  target_link_libraries(dypho_evaluate_map dypho_pipeline dypho_map_views)
  dypho_set_warnings(dypho_evaluate_map)

  if(DYPHO_WITH_ROS)
    install(TARGETS dypho_frame_source dypho_map_views LIBRARY DESTINATION ${DYPHO_LIB_DEST} ARCHIVE DESTINATION ${DYPHO_LIB_DEST})
    install(TARGETS dypho_run_dataset dypho_evaluate_map RUNTIME DESTINATION ${CATKIN_PACKAGE_BIN_DESTINATION})
  else()
    install(TARGETS dypho_frame_source dypho_map_views dypho_run_dataset dypho_evaluate_map
            RUNTIME DESTINATION ${DYPHO_BIN_DEST} LIBRARY DESTINATION ${DYPHO_LIB_DEST}
            ARCHIVE DESTINATION ${DYPHO_LIB_DEST})
  endif()
endif()
