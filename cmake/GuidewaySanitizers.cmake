# Sanitizers apply to every target of the build tree, so a sanitizer build is a separate build directory.
if(GUIDEWAY_SANITIZE STREQUAL "address")
  add_compile_options(-fsanitize=address,undefined -fno-omit-frame-pointer -fno-sanitize-recover=undefined)
  add_link_options(-fsanitize=address,undefined)
elseif(GUIDEWAY_SANITIZE STREQUAL "thread")
  add_compile_options(-fsanitize=thread -fno-omit-frame-pointer)
  add_link_options(-fsanitize=thread)
elseif(NOT GUIDEWAY_SANITIZE STREQUAL "")
  message(FATAL_ERROR "GUIDEWAY_SANITIZE must be empty, 'address' or 'thread', not '${GUIDEWAY_SANITIZE}'")
endif()

# UBSan's pointer checks, left out where ASan already reports what they would: a null or out-of-object
# access is an ASan report, and these directories cast no byte buffers (alignment). In the ASan tree
# they were 45 % of the compile time of the EXPLAIN engine (130 s -> 72 s, -O1) and 25 % of a test
# program's, and the numeric tests run faster under them (a fresh clone's ASan stage, against the
# last one on a day that compiled 1.32x faster: explain_scenarios_test-table 55 -> 43 s,
# compensation_test-set_aside 34 -> 24 s). The arithmetic checks (overflow, shift, division, float cast, bounds,
# bool/enum, vptr) stay everywhere, and every check stays in the rest of the tree.
set(GUIDEWAY_UBSAN_POINTER_CHECKS alignment,null,pointer-overflow,object-size)

# Called by the directory of the test programs: every check of the tree but UBSan's pointer checks.
function(guideway_sanitize_as_test_programs)
  if(GUIDEWAY_SANITIZE STREQUAL "address")
    add_compile_options(-fno-sanitize=${GUIDEWAY_UBSAN_POINTER_CHECKS})
  endif()
endfunction()

# Called by the directory of the numeric models (Eigen, single-threaded, pure functions of their
# inputs): under ASan, every check but UBSan's pointer checks; in the TSan tree, which runs only the
# tests labelled tsan (rings, loops, drivers, the daemon's threads) and none of the models' code, they
# are only linked: compiled plain and unoptimised (the EXPLAIN engine 48 s -> 23 s).
function(guideway_sanitize_as_numeric_models)
  guideway_sanitize_as_test_programs()
  if(GUIDEWAY_SANITIZE STREQUAL "thread")
    get_directory_property(options COMPILE_OPTIONS)
    list(REMOVE_ITEM options -fsanitize=thread)
    set_directory_properties(PROPERTIES COMPILE_OPTIONS "${options}")
    add_compile_options(-O0 -g0)
  endif()
endfunction()
