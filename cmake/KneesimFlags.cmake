# Optimised builds without NDEBUG.
#
# Debian's Simbody 3.7 is compiled without NDEBUG; code that includes Simbody headers with -DNDEBUG
# sees a different object layout and crashes in realizeTopology() (simbody#701). We therefore strip
# -DNDEBUG from every configuration and switch Eigen's own asserts off explicitly instead.
if(NOT CMAKE_BUILD_TYPE AND NOT CMAKE_CONFIGURATION_TYPES)
  set(CMAKE_BUILD_TYPE Release CACHE STRING "Build type" FORCE)
endif()
foreach(cfg RELEASE RELWITHDEBINFO MINSIZEREL)
  foreach(lang C CXX)
    string(REPLACE "-DNDEBUG" "" CMAKE_${lang}_FLAGS_${cfg} "${CMAKE_${lang}_FLAGS_${cfg}}")
  endforeach()
endforeach()
set(CMAKE_CXX_FLAGS_RELEASE "-O2" CACHE STRING "" FORCE)
add_compile_definitions($<$<NOT:$<CONFIG:Debug>>:EIGEN_NO_DEBUG>)
add_compile_options(-Wall -Wextra -Wno-unused-parameter)
