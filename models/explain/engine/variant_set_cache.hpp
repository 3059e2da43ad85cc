#pragma once
// What the selection computes again and again for one set of terms (a model, a held-out figure: drop-one
// tests, shares, re-choices ask for the same sets), kept by the set of variants within a memory budget
// (models/explain/engine). Not thread safe: one per selection.

#include <algorithm>
#include <cstddef>
#include <map>
#include <memory>
#include <utility>
#include <vector>

#include "models/explain/engine/terms.hpp"
#include "models/explain/explain.hpp"

namespace guideway::models::explain::engine {

// What the selection's caches may hold in all (ExplainOptions::memory_mb): a count of entries alone would not
// bound it, an entry's size grows with the samples.
inline std::size_t cache_budget_bytes(const ExplainOptions& options) { return options.memory_mb << 20; }

// A variant's address identifies it while its list lives, and an entry keeps the generated lists of its
// terms alive, so an address is never reused for another variant while its entry exists.
template <class V>
class VariantSetCache {
 public:
  using Key = std::vector<const Variant*>;
  explicit VariantSetCache(std::size_t budget_bytes) : budget_(budget_bytes) {}

  // The set of the terms' variants (but `skip`).
  static Key key_of(const Problem& p, const std::vector<Term>& terms, std::size_t skip) {
    Key k;
    for (std::size_t j = 0; j < terms.size(); ++j)
      if (j != skip) k.push_back(&variant_of(p, terms[j]));
    std::sort(k.begin(), k.end());
    return k;
  }

  [[nodiscard]] const V* find(const Key& key) const {
    const auto it = entries_.find(key);
    return it == entries_.end() ? nullptr : &it->second.value;
  }

  // value_bytes: what the value itself holds; the generated variants its entry keeps alive are added.
  void remember(const Key& key, const std::vector<Term>& terms, const V& value, std::size_t value_bytes) {
    Entry e{value, {}};
    std::size_t bytes = value_bytes;
    for (const auto& t : terms)
      if (t.pool) {
        e.pools.push_back(t.pool);
        for (const auto& v : *t.pool) bytes += static_cast<std::size_t>(v.block.columns.size()) * sizeof(double);
      }
    // Bounds the memory: each model holds an n x rank basis, each entry the generated variants it keeps alive.
    if (entries_.size() >= 64 || held_ + bytes > budget_) clear();
    held_ += bytes;
    entries_.emplace(key, std::move(e));
  }

  void clear() {
    entries_.clear();
    held_ = 0;
  }

 private:
  struct Entry {
    V value;
    std::vector<std::shared_ptr<const std::vector<Variant>>> pools;
  };
  std::map<Key, Entry> entries_;
  std::size_t budget_;
  std::size_t held_ = 0;
};

}  // namespace guideway::models::explain::engine
