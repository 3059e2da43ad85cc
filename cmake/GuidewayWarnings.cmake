# Project-wide warnings, linked privately by every guideway target.
add_library(guideway_warnings INTERFACE)
target_compile_options(guideway_warnings INTERFACE
  -Wall -Wextra -Wpedantic -Wshadow -Wconversion -Wno-sign-conversion -Wnon-virtual-dtor
  -Wold-style-cast -Woverloaded-virtual -Wimplicit-fallthrough)
if(GUIDEWAY_WERROR)
  target_compile_options(guideway_warnings INTERFACE -Werror)
endif()
