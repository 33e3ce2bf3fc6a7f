# The fuzz tree's flags (-DKNEESIM_FUZZ=ON, docs/fuzzing.md): every translation unit -- engine,
# plugins, fuzz targets -- compiled by clang with AddressSanitizer, UndefinedBehaviorSanitizer
# (every check fatal, so libFuzzer saves the input) and libFuzzer's coverage instrumentation.
# NDEBUG stays off as everywhere (cmake/KneesimFlags.cmake): Simbody's headers need it off.
if(NOT CMAKE_CXX_COMPILER_ID MATCHES "Clang" OR NOT CMAKE_C_COMPILER_ID MATCHES "Clang")
  message(FATAL_ERROR "KNEESIM_FUZZ needs clang (-DCMAKE_C_COMPILER=clang -DCMAKE_CXX_COMPILER=clang++), "
                      "got ${CMAKE_C_COMPILER_ID}/${CMAKE_CXX_COMPILER_ID}")
endif()
set(KNEESIM_SANITIZERS -fsanitize=address,undefined -fno-sanitize-recover=all)
add_compile_options(${KNEESIM_SANITIZERS} -fsanitize=fuzzer-no-link -fno-omit-frame-pointer -g -O1)
add_link_options(${KNEESIM_SANITIZERS})
