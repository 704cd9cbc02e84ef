# Finds CSparse (Debian's libsuitesparse-dev ships it as CXSparse: same API, cs_di_* names).
# Defines CSparse::CSparse and CSparse_FOUND.
find_path(CSparse_INCLUDE_DIR cs.h PATH_SUFFIXES suitesparse)
find_library(CSparse_LIBRARY NAMES cxsparse csparse)
include(FindPackageHandleStandardArgs)
find_package_handle_standard_args(CSparse REQUIRED_VARS CSparse_LIBRARY CSparse_INCLUDE_DIR)
if(CSparse_FOUND AND NOT TARGET CSparse::CSparse)
  add_library(CSparse::CSparse UNKNOWN IMPORTED)
  set_target_properties(CSparse::CSparse PROPERTIES
    IMPORTED_LOCATION "${CSparse_LIBRARY}"
    INTERFACE_INCLUDE_DIRECTORIES "${CSparse_INCLUDE_DIR}")
endif()
mark_as_advanced(CSparse_INCLUDE_DIR CSparse_LIBRARY)
