# Embree 3 for the reference tracer of the tests and benchmarks (tests/support/embree_ref.c,
# DESIGN.md §5): the interface target tessera_embree. Never linked into the renderer.
# pkg-config `embree3` when it exists (Debian 12's libembree-dev ships none), else the header
# and the library found directly.
if(NOT TARGET tessera_embree)
  add_library(tessera_embree INTERFACE)
  pkg_check_modules(EMBREE3 QUIET IMPORTED_TARGET embree3)
  if(EMBREE3_FOUND)
    target_link_libraries(tessera_embree INTERFACE PkgConfig::EMBREE3)
  else()
    find_path(EMBREE3_INCLUDE_DIR embree3/rtcore.h)
    find_library(EMBREE3_LIBRARY NAMES embree3)
    if(NOT EMBREE3_INCLUDE_DIR OR NOT EMBREE3_LIBRARY)
      message(FATAL_ERROR "Embree 3 not found (Debian: libembree-dev; tools/setup.sh installs it)")
    endif()
    target_include_directories(tessera_embree SYSTEM INTERFACE ${EMBREE3_INCLUDE_DIR})
    target_link_libraries(tessera_embree INTERFACE ${EMBREE3_LIBRARY})
  endif()
endif()
