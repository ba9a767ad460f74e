# The HDF5 of the CLI's snapshots and checkpoints, by pkg-config: Debian's libhdf5-dev (hdf5-serial.pc) in a build
# without MPI; in the MPI build (ECI_MPI) Debian's parallel HDF5 for Open MPI (libhdf5-openmpi-dev, hdf5-openmpi.pc),
# whose MPI-IO file driver lets every process write its block of one file at once. The names are asked for
# explicitly: Debian's plain hdf5.pc is an alternative that installing libhdf5-openmpi-dev points at the parallel
# library, which a build without MPI must not link. eci_find_hdf5(target) defines the INTERFACE target `target`.
function(eci_find_hdf5 target)
  if(TARGET ${target})
    return()
  endif()
  find_package(PkgConfig REQUIRED)
  if(ECI_MPI)
    pkg_check_modules(ECI_HDF5_PARALLEL QUIET IMPORTED_TARGET GLOBAL hdf5-openmpi)
    if(NOT ECI_HDF5_PARALLEL_FOUND)
      message(FATAL_ERROR "ECI_MPI=ON needs parallel HDF5 for Open MPI (pkg-config hdf5-openmpi; Debian: "
                          "libhdf5-openmpi-dev, installed by scripts/setup.sh): the MPI run's snapshots and "
                          "checkpoints are written by every process at once")
    endif()
    set(CMAKE_REQUIRED_INCLUDES ${ECI_HDF5_PARALLEL_INCLUDE_DIRS})
    include(CheckSymbolExists)
    check_symbol_exists(H5_HAVE_PARALLEL "hdf5.h" ECI_HDF5_HAS_PARALLEL)
    unset(CMAKE_REQUIRED_INCLUDES)
    if(NOT ECI_HDF5_HAS_PARALLEL)
      message(FATAL_ERROR "ECI_MPI=ON: the HDF5 found by pkg-config hdf5-openmpi (${ECI_HDF5_PARALLEL_INCLUDE_DIRS}) "
                          "is not built for MPI (H5_HAVE_PARALLEL)")
    endif()
    add_library(${target} INTERFACE)
    target_link_libraries(${target} INTERFACE PkgConfig::ECI_HDF5_PARALLEL)
  else()
    pkg_check_modules(ECI_HDF5_SERIAL QUIET IMPORTED_TARGET GLOBAL hdf5-serial)
    if(NOT ECI_HDF5_SERIAL_FOUND)  # (not Debian: the one HDF5 the system has)
      pkg_check_modules(ECI_HDF5_SERIAL QUIET IMPORTED_TARGET GLOBAL hdf5)
    endif()
    if(NOT ECI_HDF5_SERIAL_FOUND)
      message(FATAL_ERROR "the spectral models' snapshots and checkpoints (the tool's and Python's) need HDF5 "
                          "(pkg-config hdf5-serial or hdf5; Debian: libhdf5-dev, installed by scripts/setup.sh); or "
                          "-DECI_BUILD_SPECTRAL=OFF (pip: ECI_CMAKE_ARGS=-DECI_BUILD_SPECTRAL=OFF) builds without them")
    endif()
    add_library(${target} INTERFACE)
    target_link_libraries(${target} INTERFACE PkgConfig::ECI_HDF5_SERIAL)
  endif()
endfunction()
