# The HDF5 of the CLI's snapshots and checkpoints, by pkg-config: Debian's serial libhdf5-dev (hdf5-serial.pc), in
# the MPI build too (its processes write a file in turn, apps/eci/ns2d_output.cpp). The name is asked for explicitly:
# Debian's plain hdf5.pc is an alternative that installing libhdf5-openmpi-dev (parallel HDF5, not used yet) points at
# the parallel library. eci_find_hdf5(target) defines the INTERFACE target `target`.
function(eci_find_hdf5 target)
  if(TARGET ${target})
    return()
  endif()
  find_package(PkgConfig REQUIRED)
  pkg_check_modules(ECI_HDF5_SERIAL QUIET IMPORTED_TARGET GLOBAL hdf5-serial)
  if(NOT ECI_HDF5_SERIAL_FOUND)  # (not Debian: the one HDF5 the system has)
    pkg_check_modules(ECI_HDF5_SERIAL REQUIRED IMPORTED_TARGET GLOBAL hdf5)
  endif()
  add_library(${target} INTERFACE)
  target_link_libraries(${target} INTERFACE PkgConfig::ECI_HDF5_SERIAL)
endfunction()
