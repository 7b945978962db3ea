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
function(netkf_target_sanitizers target)
  if(NETKF_SANITIZE)
    target_compile_options(${target} PRIVATE -fsanitize=address,undefined -fno-omit-frame-pointer -fno-sanitize-recover=undefined)
    target_link_options(${target} PRIVATE -fsanitize=address,undefined)
  endif()
endfunction()
