#pragma once
// The allocator policies: of the programs that identify models (guideway, guidewayd --analyse-session, the
// benchmarks), and of guidewayd itself.

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

// guidewayd runs for months beside a CNC, and what it allocates beyond its start is a session's: its readings,
// its run files' text, its recorder's ring, a few MB each. What a session frees goes back to the kernel, so the
// daemon rests where it started and its peak is its own session's (bench/README.md, "The daemon across a
// session's EXPLAIN"). glibc's default thresholds (128 KiB), held fixed: by default glibc raises them to the
// largest block freed so far and keeps in the heap what then falls below. Its DBB sessions are analysed in a
// child that keeps freed memory (daemon/session_analysis.hpp); an analysis in the daemon pays the page faults.
inline void return_freed_memory() noexcept {
  (void)::mallopt(M_MMAP_THRESHOLD, 128 * 1024);
  (void)::mallopt(M_TRIM_THRESHOLD, 128 * 1024);
}

}  // namespace guideway
