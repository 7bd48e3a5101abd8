# TSF_WITH_IGTL = AUTO | ON | OFF  ->  TSF_HAVE_IGTL (bool), TSF_IGTL_LIBRARY and
# OpenIGTLink_INCLUDE_DIRS: the live link (docs/live.md) on Debian's libopenigtlink-dev (1.11,
# whose CMake config names directories, not an imported target).
set(TSF_HAVE_IGTL OFF)
string(TOUPPER "${TSF_WITH_IGTL}" _tsf_igtl_mode)
if(NOT _tsf_igtl_mode STREQUAL "OFF")
  find_package(OpenIGTLink QUIET)
  if(OpenIGTLink_FOUND)
    find_library(TSF_IGTL_LIBRARY NAMES OpenIGTLink HINTS ${OpenIGTLink_LIBRARY_DIRS})
  endif()
  if(OpenIGTLink_FOUND AND TSF_IGTL_LIBRARY)
    set(TSF_HAVE_IGTL ON)
  elseif(_tsf_igtl_mode STREQUAL "ON")
    message(FATAL_ERROR "TSF_WITH_IGTL=ON but OpenIGTLink was not found (Debian: "
                        "libopenigtlink-dev). Install it or use -DTSF_WITH_IGTL=OFF.")
  else()
    message(STATUS "tsf: OpenIGTLink not found, building without the live link (tsf link)")
  endif()
endif()
