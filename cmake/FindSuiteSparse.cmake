# FindSuiteSparse: CHOLMOD and SPQR from Debian's libsuitesparse-dev, which
# ships no CMake package configuration.
#
# Imported targets (each carries its include directory and dependencies):
#   SuiteSparse::config  SuiteSparse::amd  SuiteSparse::colamd  SuiteSparse::camd
#   SuiteSparse::ccolamd SuiteSparse::cholmod  SuiteSparse::spqr
# Result variables: SuiteSparse_FOUND, SuiteSparse_INCLUDE_DIR,
#   SuiteSparse_VERSION (from SuiteSparse_config.h).

find_path(SuiteSparse_INCLUDE_DIR cholmod.h
  PATH_SUFFIXES suitesparse
  DOC "Directory holding cholmod.h and SuiteSparseQR.hpp")

set(_oslam_ss_components config amd colamd camd ccolamd cholmod spqr)
set(_oslam_ss_lib_config suitesparseconfig)
foreach(component IN LISTS _oslam_ss_components)
  if(DEFINED _oslam_ss_lib_${component})
    set(_name ${_oslam_ss_lib_${component}})
  else()
    set(_name ${component})
  endif()
  find_library(SuiteSparse_${component}_LIBRARY NAMES ${_name})
  mark_as_advanced(SuiteSparse_${component}_LIBRARY)
endforeach()

if(SuiteSparse_INCLUDE_DIR AND EXISTS "${SuiteSparse_INCLUDE_DIR}/SuiteSparse_config.h")
  file(STRINGS "${SuiteSparse_INCLUDE_DIR}/SuiteSparse_config.h" _oslam_ss_version_lines
    REGEX "#define SUITESPARSE_(MAIN|SUB)_VERSION")
  string(REGEX REPLACE ".*MAIN_VERSION +([0-9]+).*" "\\1" _major "${_oslam_ss_version_lines}")
  string(REGEX REPLACE ".*SUB_VERSION +([0-9]+).*" "\\1" _minor "${_oslam_ss_version_lines}")
  set(SuiteSparse_VERSION "${_major}.${_minor}")
endif()

include(FindPackageHandleStandardArgs)
find_package_handle_standard_args(SuiteSparse
  REQUIRED_VARS SuiteSparse_INCLUDE_DIR SuiteSparse_cholmod_LIBRARY SuiteSparse_spqr_LIBRARY
    SuiteSparse_amd_LIBRARY SuiteSparse_colamd_LIBRARY SuiteSparse_config_LIBRARY
  VERSION_VAR SuiteSparse_VERSION)
mark_as_advanced(SuiteSparse_INCLUDE_DIR)

if(SuiteSparse_FOUND)
  # CHOLMOD needs LAPACK/BLAS for its supernodal kernels; the shared library
  # already links them, so nothing more is needed here.
  set(_oslam_ss_deps_config "")
  set(_oslam_ss_deps_amd SuiteSparse::config)
  set(_oslam_ss_deps_colamd SuiteSparse::config)
  set(_oslam_ss_deps_camd SuiteSparse::config)
  set(_oslam_ss_deps_ccolamd SuiteSparse::config)
  set(_oslam_ss_deps_cholmod
    SuiteSparse::amd SuiteSparse::colamd SuiteSparse::camd SuiteSparse::ccolamd SuiteSparse::config)
  set(_oslam_ss_deps_spqr SuiteSparse::cholmod SuiteSparse::config)
  foreach(component IN LISTS _oslam_ss_components)
    if(SuiteSparse_${component}_LIBRARY AND NOT TARGET SuiteSparse::${component})
      add_library(SuiteSparse::${component} UNKNOWN IMPORTED)
      set_target_properties(SuiteSparse::${component} PROPERTIES
        IMPORTED_LOCATION "${SuiteSparse_${component}_LIBRARY}"
        INTERFACE_INCLUDE_DIRECTORIES "${SuiteSparse_INCLUDE_DIR}"
        INTERFACE_LINK_LIBRARIES "${_oslam_ss_deps_${component}}")
    endif()
  endforeach()
endif()
