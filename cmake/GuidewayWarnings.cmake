# Project-wide warnings, linked privately by every guideway target.
add_library(guideway_warnings INTERFACE)
# The C++-only ones guarded, as C driver plugins link it too.
target_compile_options(guideway_warnings INTERFACE
  -Wall -Wextra -Wpedantic -Wshadow -Wconversion -Wno-sign-conversion $<$<COMPILE_LANGUAGE:CXX>:-Wnon-virtual-dtor>
  $<$<COMPILE_LANGUAGE:CXX>:-Wold-style-cast> $<$<COMPILE_LANGUAGE:CXX>:-Woverloaded-virtual> -Wimplicit-fallthrough
  # GCC 12 at -O3 (Release) reports std::string concatenations as overlapping copies (GCC bug 105329).
  $<$<AND:$<CXX_COMPILER_ID:GNU>,$<VERSION_LESS:$<CXX_COMPILER_VERSION>,13>>:-Wno-restrict>)
if(GUIDEWAY_WERROR)
  target_compile_options(guideway_warnings INTERFACE -Werror)
endif()
