# The compression libraries of MCAP chunks, from Debian's libzstd-dev and liblz4-dev (no
# CMake config for lz4 on Debian 12). Defines the imported targets Zstd::Zstd and LZ4::LZ4.
find_path(ZSTD_INCLUDE_DIR zstd.h)
find_library(ZSTD_LIBRARY zstd)
find_path(LZ4_INCLUDE_DIR lz4frame.h)
find_library(LZ4_LIBRARY lz4)
include(FindPackageHandleStandardArgs)
find_package_handle_standard_args(McapCompression DEFAULT_MSG
  ZSTD_INCLUDE_DIR ZSTD_LIBRARY LZ4_INCLUDE_DIR LZ4_LIBRARY)
if(McapCompression_FOUND AND NOT TARGET Zstd::Zstd)
  add_library(Zstd::Zstd UNKNOWN IMPORTED)
  set_target_properties(Zstd::Zstd PROPERTIES
    IMPORTED_LOCATION "${ZSTD_LIBRARY}" INTERFACE_INCLUDE_DIRECTORIES "${ZSTD_INCLUDE_DIR}")
  add_library(LZ4::LZ4 UNKNOWN IMPORTED)
  set_target_properties(LZ4::LZ4 PROPERTIES
    IMPORTED_LOCATION "${LZ4_LIBRARY}" INTERFACE_INCLUDE_DIRECTORIES "${LZ4_INCLUDE_DIR}")
endif()
mark_as_advanced(ZSTD_INCLUDE_DIR ZSTD_LIBRARY LZ4_INCLUDE_DIR LZ4_LIBRARY)
