#pragma once
// The allocator policy of the programs that identify models (guidewayd, guideway, the benchmarks).

#include <malloc.h>

namespace guideway {

// An identification allocates a few MB per call (design matrices, per-point tables). By default glibc
// hands blocks that large back to the kernel on free, so every call touches fresh pages again: about
// 3 ms of page faults in a ~9 ms DBB identification on this project's VM (bench/README.md). Keeping
// freed memory for reuse costs RSS at the peak instead. Thresholds: glibc's largest allowed mmap
// threshold (32 MiB on 64-bit), and no trimming below 256 MiB of free heap.
inline void keep_freed_memory() noexcept {
  (void)::mallopt(M_MMAP_THRESHOLD, 32 * 1024 * 1024);
  (void)::mallopt(M_TRIM_THRESHOLD, 256 * 1024 * 1024);
}

}  // namespace guideway
