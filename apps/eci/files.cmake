# The files of a run, shared by the tool (apps/eci) and the Python module (python/): files committed by rename, the
# signal handling, the CLI's error kinds and the run's pictures (eci_cli_output), and the spectral equations' HDF5
# snapshots and checkpoints (eci_cli_ns2d_output, where eci::spectral is built). Included by both directories; the
# targets are defined once, position-independent so that the Python extension can link them. The pip build
# (setup.py) builds the Python module alone, without the tool, and gets them from here.
if(NOT TARGET eci_cli_output)
  add_library(eci_cli_output STATIC ${CMAKE_CURRENT_LIST_DIR}/output.cpp ${CMAKE_CURRENT_LIST_DIR}/run_plot.cpp)
  set_target_properties(eci_cli_output PROPERTIES POSITION_INDEPENDENT_CODE ON)
  target_link_libraries(eci_cli_output PUBLIC eci PRIVATE eci_warnings)  # (eci/format.hpp: numbers in messages)
  target_include_directories(eci_cli_output PUBLIC ${CMAKE_CURRENT_LIST_DIR})
endif()
# ns2d_output.cpp is the one file that includes hdf5.h (a library of its own so that HDF5's flags reach no other
# file): the serial HDF5 (libhdf5-dev), or in the MPI build parallel HDF5 (libhdf5-openmpi-dev), with which every
# process writes its block of a file at once (cmake/hdf5.cmake).
if(TARGET eci::spectral AND NOT TARGET eci_cli_ns2d_output)
  include(${PROJECT_SOURCE_DIR}/cmake/hdf5.cmake)
  eci_find_hdf5(eci_hdf5)
  add_library(eci_cli_ns2d_output STATIC ${CMAKE_CURRENT_LIST_DIR}/ns2d_output.cpp)
  set_target_properties(eci_cli_ns2d_output PROPERTIES POSITION_INDEPENDENT_CODE ON)
  target_link_libraries(eci_cli_ns2d_output PRIVATE eci::spectral eci_hdf5 eci_warnings eci_cli_output)
  target_include_directories(eci_cli_ns2d_output PRIVATE ${CMAKE_CURRENT_LIST_DIR})
endif()
