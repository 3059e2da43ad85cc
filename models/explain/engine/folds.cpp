// EXPLAIN's held-out rows (folds.hpp).
#include "models/explain/engine/folds.hpp"

#include <algorithm>
#include <atomic>

#include "models/explain/engine/subspace.hpp"

namespace guideway::models::explain::engine {

HeldOutScheme heldout_scheme(const Problem& problem, const ExplainOptions& options,
                             const std::vector<std::pair<std::size_t, std::size_t>>& ranges) {
  const std::size_t n = problem.samples.size();
  HeldOutScheme h{std::vector<int>(n, 0), static_cast<int>(std::max<std::size_t>(options.folds, 2)), {}};
  if (problem.station_means_absorbed && problem.station_of.size() == n) {
    // Whole stations: a station's mean is fitted out of its readings (Problem::station_means_absorbed), so a fold
    // keeps or holds out all of them, and what is predicted is how the held-out station's readings disagree.
    for (std::size_t i = 0; i < n; ++i)
      h.fold_of[i] = static_cast<int>(problem.station_of[i] % static_cast<std::size_t>(h.folds));
    h.name = "interleaved " + std::to_string(h.folds) + "-fold cross-validation (every " + std::to_string(h.folds) +
             "th station, all its readings: their disagreement predicted)";
    return h;
  }
  bool loro = false;
  if (problem.runs.size() >= 3 && !problem.terms_per_run && problem.base.columns.cols() > 0) {
    const std::size_t full_rank = static_cast<std::size_t>(span_basis(problem.base.columns).cols());
    loro = true;
    for (std::size_t k = 0; k < ranges.size() && loro; ++k) {
      std::vector<Eigen::Index> train;
      for (std::size_t i = 0; i < n; ++i)
        if (problem.samples[i].run != k) train.push_back(static_cast<Eigen::Index>(i));
      loro = static_cast<std::size_t>(span_basis(problem.base.columns(train, Eigen::all)).cols()) == full_rank;
    }
  }
  if (loro) {
    h.folds = static_cast<int>(problem.runs.size());
    for (std::size_t i = 0; i < n; ++i) h.fold_of[i] = static_cast<int>(problem.samples[i].run);
    h.name = "leave-one-run-out (" + std::to_string(h.folds) + " runs)";
    return h;
  }
  if (problem.station_of.size() == n) {
    // Every k-th station of each run, shifted by one from run to run: a station held out in one run is a training
    // row in the next, and every held-out station has training stations on both sides but at the grid's ends.
    for (std::size_t i = 0; i < n; ++i)
      h.fold_of[i] = static_cast<int>((problem.station_of[i] + problem.samples[i].run) % static_cast<std::size_t>(h.folds));
    h.name = "interleaved " + std::to_string(h.folds) + "-fold cross-validation (every " + std::to_string(h.folds) +
             "th station of every run, shifted run to run)";
    return h;
  }
  for (std::size_t k = 0; k < ranges.size(); ++k) {
    const auto [a, b] = ranges[k];
    const std::size_t len = b - a;
    for (std::size_t i = a; i < b; ++i) {
      const auto block = static_cast<int>((i - a) * static_cast<std::size_t>(h.folds) / std::max<std::size_t>(len, 1));
      h.fold_of[i] = (block + static_cast<int>(k)) % h.folds;
    }
  }
  h.name = "blocked " + std::to_string(h.folds) + "-fold cross-validation (contiguous blocks of every run)";
  return h;
}

std::size_t absorbed_rank(const Problem& problem) {
  if (!problem.station_means_absorbed || problem.station_of.empty()) return 0;
  std::vector<std::size_t> stations = problem.station_of;
  std::sort(stations.begin(), stations.end());
  return static_cast<std::size_t>(std::unique(stations.begin(), stations.end()) - stations.begin());
}

std::vector<FoldRows> fold_rows(const std::vector<int>& fold_of, int folds) {
  std::vector<FoldRows> out(static_cast<std::size_t>(folds));
  for (int f = 0; f < folds; ++f) {
    auto& fr = out[static_cast<std::size_t>(f)];
    fr.use.assign(fold_of.size(), false);
    for (std::size_t i = 0; i < fold_of.size(); ++i) {
      const bool held = fold_of[i] == f;
      if (held) fr.test.push_back(static_cast<Eigen::Index>(i));
      fr.use[i] = !held;
    }
  }
  return out;
}

FoldBlock fold_block(const Variant& v, bool listed) {
  static std::atomic<std::uint64_t> ids{0};
  if (listed) return {std::shared_ptr<const Variant>(std::shared_ptr<const Variant>(), &v), ++ids};
  return {std::make_shared<const Variant>(v), ++ids};
}

}  // namespace guideway::models::explain::engine
