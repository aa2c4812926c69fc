# One place for compiler warnings and sanitizer flags; every target calls rgbdmap_target_defaults().
function(rgbdmap_target_defaults target)
  target_compile_options(${target} PRIVATE -Wall -Wextra -Wpedantic)
  if(RGBDMAP_WERROR)
    target_compile_options(${target} PRIVATE -Werror)
  endif()
  if(CMAKE_UNITY_BUILD)
    # A source's anonymous-namespace types used in its own classes are fine; a unity build includes the source
    # into another file, where GCC takes it for a header and warns.
    target_compile_options(${target} PRIVATE $<$<COMPILE_LANGUAGE:CXX>:-Wno-subobject-linkage>)
  endif()
  if(RGBDMAP_SANITIZE)
    # -O1 -g1 (after the build type's flags): what ASan recommends, line tables for the reports, and a tree
    # that compiles in about half the time of -O2 -g.
    target_compile_options(${target} PRIVATE -fsanitize=address,undefined -fno-omit-frame-pointer -O1 -g1)
    target_link_options(${target} PRIVATE -fsanitize=address,undefined)
  endif()
endfunction()
