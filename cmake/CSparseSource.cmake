# CSparse compiled from source into pgem_core, with its allocator replaced by the block's pool
# (lib/core/linalg/cs_pool.c). PGEM_CSPARSE_SOURCE_DIR is a SuiteSparse source tree, or its
# CXSparse folder, e.g. what tools/fetch-csparse unpacks from Debian's suitesparse source package.
#
# Defines:
#   PGEM_CSPARSE_SOURCES       the CSparse files the core needs (cs_malloc.c left out)
#   CSparse::CSparse           an interface target carrying CSparse's include folders
set(_pgem_cs_root "${PGEM_CSPARSE_SOURCE_DIR}")
set(_pgem_cs_dir "")
foreach(candidate "${_pgem_cs_root}/CXSparse" "${_pgem_cs_root}")
  if(EXISTS "${candidate}/Source/cs_amd.c" AND EXISTS "${candidate}/Include/cs.h")
    set(_pgem_cs_dir "${candidate}")
    break()
  endif()
endforeach()
if(NOT _pgem_cs_dir)
  message(FATAL_ERROR
    "PGEM_CSPARSE_SOURCE_DIR=${PGEM_CSPARSE_SOURCE_DIR} holds no CSparse sources "
    "(looked for CXSparse/Source/cs_amd.c and Source/cs_amd.c). Run tools/fetch-csparse, which "
    "unpacks them from Debian's suitesparse source package into build/_deps/suitesparse.")
endif()
set(_pgem_cs_config "")
foreach(candidate "${_pgem_cs_dir}/../SuiteSparse_config" "${_pgem_cs_root}/SuiteSparse_config")
  if(EXISTS "${candidate}/SuiteSparse_config.h")
    get_filename_component(_pgem_cs_config "${candidate}" ABSOLUTE)
    break()
  endif()
endforeach()
if(NOT _pgem_cs_config)
  message(FATAL_ERROR "PGEM_CSPARSE_SOURCE_DIR: CXSparse found in ${_pgem_cs_dir}, but not "
                      "SuiteSparse_config/SuiteSparse_config.h beside it")
endif()

# The routines the core calls (amd, etree, post, counts, ereach) and what
# they call in turn (cs_amd links cs_multiply for orderings the core does not use). cs_malloc.c
# is replaced by the pool.
set(PGEM_CSPARSE_SOURCES "")
foreach(name amd etree post counts ereach add transpose fkeep util tdfs leaf
             cumsum scatter multiply)
  list(APPEND PGEM_CSPARSE_SOURCES "${_pgem_cs_dir}/Source/cs_${name}.c")
endforeach()
# Third-party code: built with the project's warnings as errors, less the few its own style
# trips (applied where the library target is defined, as source properties are per folder).
set(PGEM_CSPARSE_COMPILE_OPTIONS -Wno-unused-parameter -Wno-sign-compare -Wno-missing-prototypes
    -Wno-strict-prototypes -Wno-shadow -Wno-double-promotion -Wno-cast-qual)

if(NOT TARGET CSparse::CSparse)
  add_library(CSparse::CSparse INTERFACE IMPORTED)
  set_target_properties(CSparse::CSparse PROPERTIES
    INTERFACE_INCLUDE_DIRECTORIES "${_pgem_cs_dir}/Include;${_pgem_cs_config}")
endif()
message(STATUS "CSparse: compiled from ${_pgem_cs_dir} with the block's allocator")
