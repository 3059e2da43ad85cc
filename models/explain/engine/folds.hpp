#pragma once
// EXPLAIN's held-out rows (models/explain/engine, docs/explain.md "Held out"): whole runs, interleaved stations or
// contiguous blocks of every run, the rows of each fold, and a term's columns on a fold's training and held-out rows.
// Pure functions; thread safe.

#include <cstdint>
#include <memory>
#include <string>
#include <utility>
#include <vector>

#include <Eigen/Core>

#include "models/explain/explain.hpp"

namespace guideway::models::explain::engine {

// The held-out rows: every k-th station whole where the stations' means are fitted out of the data
// (Problem::station_means_absorbed); else whole runs when there are at least three, the base is still determined
// without any one of them and no candidate has terms of one run alone; otherwise, for a problem with stations (a
// traverse: Problem::station_of), every k-th station of each run, shifted run to run (a fold never extrapolates the
// base); otherwise contiguous blocks of every run (staggered between runs).
struct HeldOutScheme {
  std::vector<int> fold_of;
  int folds = 0;
  std::string name;
};
HeldOutScheme heldout_scheme(const Problem& problem, const ExplainOptions& options,
                             const std::vector<std::pair<std::size_t, std::size_t>>& ranges);

// The terms a problem's base holds beyond its columns: one per station where the stations' means are fitted out
// of the data (Problem::station_means_absorbed), counted in every model's rank.
std::size_t absorbed_rank(const Problem& problem);

// The rows of each fold.
struct FoldRows {
  std::vector<Eigen::Index> test;
  std::vector<bool> use;  // use[i]: sample i is a training row of this fold
  [[nodiscard]] std::size_t train_rows() const { return use.size() - test.size(); }
};
std::vector<FoldRows> fold_rows(const std::vector<int>& fold_of, int folds);

// A term's columns in one fold: the variant chosen on that fold's training rows (every row of it).
struct FoldBlock {
  std::shared_ptr<const Variant> variant;
  std::uint64_t id = 0;  // names these columns for the fold models' cache (0: none)
};
// A listed variant (one of the problem's, which outlives the selection) is referred to, a generated one copied
// out of its list (the rest of the list is not kept for it).
FoldBlock fold_block(const Variant& v, bool listed);

}  // namespace guideway::models::explain::engine
