# guideway_embed_text(INPUT file OUTPUT file.inc): writes the file's text as a C++ raw string literal,
# for `constexpr std::string_view x =\n#include "file.inc"\n;`. Regenerated when the input changes.
function(guideway_embed_text)
  cmake_parse_arguments(E "" "INPUT;OUTPUT" "" ${ARGN})
  file(READ ${E_INPUT} text)
  set(content "R\"guideway_embed(${text})guideway_embed\"\n")
  if(EXISTS ${E_OUTPUT})
    file(READ ${E_OUTPUT} old)
  endif()
  if(NOT "${old}" STREQUAL "${content}")
    file(WRITE ${E_OUTPUT} "${content}")
  endif()
  set_property(DIRECTORY APPEND PROPERTY CMAKE_CONFIGURE_DEPENDS ${E_INPUT})
endfunction()
