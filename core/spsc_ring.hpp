#pragma once
// Lock-free single-producer/single-consumer ring buffer.
// Thread safe for exactly one producer thread and one consumer thread; the observers
// (depth, free_slots, drops) may be called from any thread and return a momentary view.

#include <algorithm>
#include <atomic>
#include <bit>
#include <cstddef>
#include <cstdint>
#include <memory>
#include <new>
#include <span>
#include <stdexcept>
#include <type_traits>

namespace guideway {

inline constexpr std::size_t cache_line_bytes = 64;

template <class T>
class SpscRing {
  static_assert(std::is_trivially_copyable_v<T>, "ring elements are copied with memcpy semantics");

 public:
  // capacity must be a power of two >= 2 (so index & mask replaces modulo).
  explicit SpscRing(std::size_t capacity)
      : capacity_(capacity), mask_(capacity - 1) {
    if (capacity < 2 || !std::has_single_bit(capacity)) {
      throw std::invalid_argument("SpscRing capacity must be a power of two >= 2");
    }
    // Cache-line aligned slots: a 64-byte Sample then occupies exactly one line, never two.
    slots_.reset(new (std::align_val_t{slot_alignment}) T[capacity]());
  }
  SpscRing(const SpscRing&) = delete;
  SpscRing& operator=(const SpscRing&) = delete;

  // Producer: never blocks. Returns false and counts one drop when the ring is full.
  bool try_push(const T& item) noexcept {
    const std::uint64_t head = producer_.head.load(std::memory_order_relaxed);
    if (head - producer_.cached_tail == capacity_) {
      producer_.cached_tail = consumer_.tail.load(std::memory_order_acquire);
      if (head - producer_.cached_tail == capacity_) {
        count_drops(1);
        return false;
      }
    }
    slots_[head & mask_] = item;
    producer_.head.store(head + 1, std::memory_order_release);
    return true;
  }

  // Producer: pushes as many leading items as fit, counts the rest as drops, returns how many
  // were pushed. One release store publishes the whole span.
  std::size_t push_bulk(std::span<const T> items) noexcept {
    const std::size_t n = try_push_bulk(items);
    if (n < items.size()) count_drops(items.size() - n);
    return n;
  }

  // Producer: like push_bulk, but what does not fit is left to the caller (not counted as dropped),
  // for a producer that can hold data back and retry.
  std::size_t try_push_bulk(std::span<const T> items) noexcept {
    const std::uint64_t head = producer_.head.load(std::memory_order_relaxed);
    std::size_t room = capacity_ - static_cast<std::size_t>(head - producer_.cached_tail);
    if (room < items.size()) {
      producer_.cached_tail = consumer_.tail.load(std::memory_order_acquire);
      room = capacity_ - static_cast<std::size_t>(head - producer_.cached_tail);
    }
    const std::size_t n = items.size() < room ? items.size() : room;
    copy_in(head, items.first(n));
    if (n != 0) producer_.head.store(head + n, std::memory_order_release);
    return n;
  }

  // Consumer: returns false when empty.
  bool try_pop(T& out) noexcept {
    const std::uint64_t tail = consumer_.tail.load(std::memory_order_relaxed);
    if (tail == consumer_.cached_head) {
      consumer_.cached_head = producer_.head.load(std::memory_order_acquire);
      if (tail == consumer_.cached_head) return false;
    }
    out = slots_[tail & mask_];
    consumer_.tail.store(tail + 1, std::memory_order_release);
    return true;
  }

  // Consumer: pops up to out.size() items, returns how many.
  std::size_t pop_bulk(std::span<T> out) noexcept {
    const std::uint64_t tail = consumer_.tail.load(std::memory_order_relaxed);
    std::size_t available = static_cast<std::size_t>(consumer_.cached_head - tail);
    if (available < out.size()) {
      consumer_.cached_head = producer_.head.load(std::memory_order_acquire);
      available = static_cast<std::size_t>(consumer_.cached_head - tail);
    }
    const std::size_t n = out.size() < available ? out.size() : available;
    copy_out(tail, out.first(n));
    if (n != 0) consumer_.tail.store(tail + n, std::memory_order_release);
    return n;
  }

  [[nodiscard]] std::size_t capacity() const noexcept { return capacity_; }
  [[nodiscard]] std::size_t depth() const noexcept {
    const std::uint64_t tail = consumer_.tail.load(std::memory_order_acquire);
    const std::uint64_t head = producer_.head.load(std::memory_order_acquire);
    // Loaded tail first: head >= tail always holds, the difference never exceeds capacity.
    const std::uint64_t d = head - tail;
    return static_cast<std::size_t>(d > capacity_ ? capacity_ : d);
  }
  [[nodiscard]] std::size_t free_slots() const noexcept { return capacity_ - depth(); }
  [[nodiscard]] std::uint64_t drops() const noexcept { return producer_.drops.load(std::memory_order_relaxed); }
  [[nodiscard]] std::uint64_t pushed() const noexcept { return producer_.head.load(std::memory_order_acquire); }
  [[nodiscard]] std::uint64_t popped() const noexcept { return consumer_.tail.load(std::memory_order_acquire); }

 private:
  void count_drops(std::size_t n) noexcept {
    // Only the producer writes: a relaxed load+store is enough and avoids a locked RMW.
    producer_.drops.store(producer_.drops.load(std::memory_order_relaxed) + n, std::memory_order_relaxed);
  }
  void copy_in(std::uint64_t head, std::span<const T> items) noexcept {
    const std::size_t start = head & mask_;
    const std::size_t first = items.size() < capacity_ - start ? items.size() : capacity_ - start;
    std::copy_n(items.data(), first, slots_.get() + start);
    std::copy_n(items.data() + first, items.size() - first, slots_.get());
  }
  void copy_out(std::uint64_t tail, std::span<T> out) const noexcept {
    const std::size_t start = tail & mask_;
    const std::size_t first = out.size() < capacity_ - start ? out.size() : capacity_ - start;
    std::copy_n(slots_.get() + start, first, out.data());
    std::copy_n(slots_.get(), out.size() - first, out.data() + first);
  }

  // Producer-owned line: its index, its cached view of the consumer, its drop counter.
  struct alignas(cache_line_bytes) ProducerSide {
    std::atomic<std::uint64_t> head{0};
    std::uint64_t cached_tail = 0;
    std::atomic<std::uint64_t> drops{0};
  };
  // Consumer-owned line.
  struct alignas(cache_line_bytes) ConsumerSide {
    std::atomic<std::uint64_t> tail{0};
    std::uint64_t cached_head = 0;
  };

  static constexpr std::size_t slot_alignment = alignof(T) > cache_line_bytes ? alignof(T) : cache_line_bytes;
  struct AlignedDelete {
    void operator()(T* p) const noexcept { ::operator delete[](p, std::align_val_t{slot_alignment}); }
  };

  const std::size_t capacity_;
  const std::size_t mask_;
  std::unique_ptr<T[], AlignedDelete> slots_;
  ProducerSide producer_;
  ConsumerSide consumer_;
};

}  // namespace guideway
