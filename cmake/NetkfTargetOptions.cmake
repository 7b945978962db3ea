# Per-target warnings and sanitizers: applied to netkf's own targets only, never
# globally, so generated and third-party code keeps its own flags.
function(netkf_target_options target)
  target_compile_options(${target} PRIVATE
    -Wall -Wextra -Wpedantic -Wshadow -Wnon-virtual-dtor -Wcast-align
    -Woverloaded-virtual -Wnull-dereference -Wdouble-promotion -Wformat=2
    $<$<BOOL:${NETKF_WERROR}>:-Werror>)
  netkf_target_sanitizers(${target})
endfunction()

# Sanitizers alone (for targets such as generated DDS code that keep their own warnings).
# The fuzz build (NETKF_FUZZ) has them too, and libFuzzer's coverage instrumentation
# (fuzzer-no-link: the fuzzer executables link libFuzzer itself, tests/fuzz).
function(netkf_target_sanitizers target)
  if(NETKF_SANITIZE OR NETKF_FUZZ)
    target_compile_options(${target} PRIVATE -fsanitize=address,undefined -fno-omit-frame-pointer -fno-sanitize-recover=undefined)
    target_link_options(${target} PRIVATE -fsanitize=address,undefined)
  endif()
  if(NETKF_FUZZ)
    target_compile_options(${target} PRIVATE -fsanitize=fuzzer-no-link)
  endif()
endfunction()

# netkf_add_node(<name> LOGIC <lib> SOURCES <src...> [APP <lib> APP_SOURCES <src...>]): a
# node's DDS-free logic library (registered for unit tests and benches) and, with DDS, its
# app library (the node's DDS wiring as a class with run()/stop(), registered for the
# integration tests, which run it in process) and its thin executable src/main.cpp.
function(netkf_add_node name)
  cmake_parse_arguments(ARG "" "LOGIC;APP" "SOURCES;LOGIC_DEPS;APP_SOURCES" ${ARGN})
  add_library(${ARG_LOGIC} ${ARG_SOURCES})
  target_include_directories(${ARG_LOGIC} PUBLIC ${CMAKE_CURRENT_SOURCE_DIR}/include)
  target_link_libraries(${ARG_LOGIC} PUBLIC ${ARG_LOGIC_DEPS} netkf::core)
  netkf_target_options(${ARG_LOGIC})
  set_property(GLOBAL APPEND PROPERTY NETKF_LOGIC_LIBS ${ARG_LOGIC})
  if(NETKF_WITH_DDS)
    set(main_deps ${ARG_LOGIC} netkf_node_main)
    if(ARG_APP)
      add_library(${ARG_APP} ${ARG_APP_SOURCES})
      target_link_libraries(${ARG_APP} PUBLIC ${ARG_LOGIC} netkf_dds)
      netkf_target_options(${ARG_APP})
      # Boost 1.74 Asio's scheduler trips a false -Wnull-dereference when inlined (GCC 12).
      target_compile_options(${ARG_APP} PRIVATE -Wno-null-dereference)
      set_property(GLOBAL APPEND PROPERTY NETKF_APP_LIBS ${ARG_APP})
      list(APPEND main_deps ${ARG_APP})
    endif()
    add_executable(${name} src/main.cpp)
    target_link_libraries(${name} PRIVATE ${main_deps})
    netkf_target_options(${name})
    target_compile_options(${name} PRIVATE -Wno-null-dereference)
  endif()
endfunction()
