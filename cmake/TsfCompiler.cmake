# Warnings, sanitizers and OpenMP as interface targets that every tsf target links.
find_package(OpenMP REQUIRED COMPONENTS CXX)

add_library(tsf_warnings INTERFACE)
set(_tsf_cxx_warnings -Wall -Wextra -Wpedantic -Wshadow -Wnon-virtual-dtor -Wcast-align
    -Woverloaded-virtual -Wdouble-promotion -Wformat=2 -Wimplicit-fallthrough)
if(TSF_WERROR)
  list(APPEND _tsf_cxx_warnings -Werror)
endif()
target_compile_options(tsf_warnings INTERFACE $<$<COMPILE_LANGUAGE:CXX>:${_tsf_cxx_warnings}>)
# nvcc: forward the host-compiler warnings that make sense for generated code.
target_compile_options(tsf_warnings INTERFACE
  $<$<COMPILE_LANGUAGE:CUDA>:-Xcompiler=-Wall,-Wextra --Werror=cross-execution-space-call>)

add_library(tsf_sanitize INTERFACE)
if(TSF_SANITIZE)
  set(_san -fsanitize=address,undefined -fno-omit-frame-pointer -fno-sanitize-recover=undefined)
  target_compile_options(tsf_sanitize INTERFACE $<$<COMPILE_LANGUAGE:CXX>:${_san}>)
  # Line tables are all a sanitizer report needs; full debug info (variable tracking) took the
  # CPU kernels' file from 21 to 37 minutes of a core under ASan.
  target_compile_options(tsf_sanitize INTERFACE $<$<AND:$<COMPILE_LANGUAGE:CXX>,$<CONFIG:RelWithDebInfo,Debug>>:-g1>)
  target_link_options(tsf_sanitize INTERFACE ${_san})
endif()

# Fuzzing (fuzz/): every tsf target gets libFuzzer's coverage instrumentation; only the harness
# executables link libFuzzer itself (-fsanitize=fuzzer, fuzz/CMakeLists.txt).
if(TSF_FUZZ)
  if(NOT CMAKE_CXX_COMPILER_ID STREQUAL "Clang")
    message(FATAL_ERROR "TSF_FUZZ needs clang (-DCMAKE_CXX_COMPILER=clang++ -DCMAKE_C_COMPILER=clang)")
  endif()
  target_compile_options(tsf_sanitize INTERFACE
                         $<$<COMPILE_LANGUAGE:CXX>:-fsanitize=fuzzer-no-link>)
endif()

# Every tsf target: warnings + sanitizer flags.
function(tsf_target_defaults target)
  target_link_libraries(${target} PRIVATE tsf_warnings tsf_sanitize)
endfunction()
