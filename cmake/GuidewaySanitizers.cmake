# Sanitizers apply to every target of the build tree, so a sanitizer build is a separate build directory.
# GUIDEWAY_SANITIZED_ADDRESS / _THREAD tell the code which one, whatever the compiler (GCC defines
# __SANITIZE_ADDRESS__, clang 14 only answers __has_feature): tests skip statistics and timing ratios there.
if(GUIDEWAY_SANITIZE STREQUAL "address")
  add_compile_options(-fsanitize=address,undefined -fno-omit-frame-pointer -fno-sanitize-recover=undefined)
  add_link_options(-fsanitize=address,undefined)
  add_compile_definitions(GUIDEWAY_SANITIZED_ADDRESS=1)
elseif(GUIDEWAY_SANITIZE STREQUAL "thread")
  add_compile_options(-fsanitize=thread -fno-omit-frame-pointer)
  add_link_options(-fsanitize=thread)
  add_compile_definitions(GUIDEWAY_SANITIZED_THREAD=1)
elseif(NOT GUIDEWAY_SANITIZE STREQUAL "")
  message(FATAL_ERROR "GUIDEWAY_SANITIZE must be empty, 'address' or 'thread', not '${GUIDEWAY_SANITIZE}'")
endif()
