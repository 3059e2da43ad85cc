// core/memory_policy.hpp: where a freed block of a few MB goes under each allocator policy, by glibc's own counts
// (mallinfo2: bytes in mmapped blocks, free bytes the heap keeps). Each test sets the policy it checks (both are
// process-wide and set both thresholds).
#include "core/memory_policy.hpp"

#include <gtest/gtest.h>
#include <malloc.h>

#include <cstddef>
#include <cstdlib>
#include <cstring>

#include "sanitizer_build.hpp"

namespace {

constexpr std::size_t block_bytes = std::size_t{8} << 20;  // a session's buffers are a few MB each

struct Counts {
  std::size_t mmapped_before = 0;  // mallinfo2().hblkhd
  std::size_t mmapped_while_held = 0;
  std::size_t mmapped_after = 0;
  std::size_t heap_free_before = 0;  // mallinfo2().fordblks
  std::size_t heap_free_after = 0;
};

// Allocates a block, writes every page of it, frees it: glibc's counts around.
Counts allocate_write_free() {
  Counts c;
  c.mmapped_before = ::mallinfo2().hblkhd;
  c.heap_free_before = ::mallinfo2().fordblks;
  void* p = std::malloc(block_bytes);
  if (p == nullptr) return c;
  std::memset(p, 1, block_bytes);
  asm volatile("" : : "g"(p) : "memory");  // the block is used: the compiler keeps the malloc and free
  c.mmapped_while_held = ::mallinfo2().hblkhd;
  std::free(p);
  c.mmapped_after = ::mallinfo2().hblkhd;
  c.heap_free_after = ::mallinfo2().fordblks;
  return c;
}

#if defined(GUIDEWAY_SANITIZED_ADDRESS) || defined(GUIDEWAY_SANITIZED_THREAD)
constexpr bool glibc_malloc = false;  // the sanitizer's allocator replaces glibc's: mallopt sets nothing
#else
constexpr bool glibc_malloc = true;
#endif

}  // namespace

// guidewayd: a freed block goes back to the kernel, every time. glibc's default would do it once, then raise
// its threshold to that block's size and keep the next such block in the heap (the second round below).
TEST(MemoryPolicy, ReturnFreedMemoryGivesEveryFreedBlockBackToTheKernel) {
  if (!glibc_malloc) GTEST_SKIP() << "a sanitizer's allocator";
  guideway::return_freed_memory();
  for (int round = 0; round < 3; ++round) {
    SCOPED_TRACE(round);
    const Counts c = allocate_write_free();
    // Mapped on its own and unmapped, or taken from the heap and trimmed: either way glibc holds it no more.
    EXPECT_EQ(c.mmapped_after, c.mmapped_before) << "a mapped block is unmapped when freed";
    EXPECT_LT(c.heap_free_after, block_bytes) << "nor kept in the heap";
  }
}

// guideway and guidewayd --analyse-session: a freed block stays in the heap for the next identification.
TEST(MemoryPolicy, KeepFreedMemoryKeepsAFreedBlockInTheHeap) {
  if (!glibc_malloc) GTEST_SKIP() << "a sanitizer's allocator";
  guideway::keep_freed_memory();
  for (int round = 0; round < 2; ++round) {
    SCOPED_TRACE(round);
    const Counts c = allocate_write_free();
    EXPECT_EQ(c.mmapped_while_held, c.mmapped_before) << "taken from the heap, not mapped";
    EXPECT_GE(c.heap_free_after, block_bytes) << "kept in the heap when freed";
  }
}
