#pragma once
// The base of a problem factored group by group (models/explain/engine): the held-out folds' rows are the groups,
// and every set of rows the selection fits on -- every row, or a fold's training rows, every group but one -- is a
// union of groups. Each group's base rows are factored once, Q_g R_g; a row set's base is then the QR of the
// stacked R_g of its groups, Q_S = blockdiag(Q_g) W_S (a few p x p blocks), so one n x p matrix of the groups' Q
// serves every fold, and a column's products with a fold's base are the groups' products, combined. Rows are in
// the problem's order, each group a list of contiguous ranges of them. Not thread safe (the row sets' factors are
// made when first asked for).

#include <cstddef>
#include <memory>
#include <utility>
#include <vector>

#include <Eigen/Core>

namespace guideway::models::explain::engine {

class GroupedBase {
 public:
  using Ranges = std::vector<std::pair<Eigen::Index, Eigen::Index>>;  // [first, end) of each contiguous stretch
  static constexpr std::size_t all = static_cast<std::size_t>(-1);    // no group left out: every row

  // The base's columns (n x p, p may be 0; columns zero on every row are left out) and each row's group
  // (0 .. groups - 1).
  // `absorbed`: terms of the base fitted out of the data rather than given as columns (absorbed_rank, folds.hpp),
  // counted in every model's rank.
  GroupedBase(const Eigen::MatrixXd& base, const std::vector<int>& group_of, std::size_t groups,
              std::size_t absorbed = 0);

  // The base on the rows of every group but `skip` (all: every row).
  struct Span {
    std::vector<std::size_t> members;  // its groups, in the order their blocks are stacked
    Eigen::Index rows = 0;             // rows in the set
    Eigen::MatrixXd w;                 // (members p) x p: the set's base = blockdiag(Q_g) w r (w orthonormal)
    Eigen::MatrixXd r;                 // p x p, for the columns scaled to unit norm on the set's rows (`scale`)
    Eigen::VectorXd scale;             // 1 / each column's norm on the set's rows (1 for a zero column)
    // An orthonormal basis of the span of the base's columns on the set: blockdiag(Q_g) v, of the rank a
    // column-pivoted QR with threshold rank_tolerance gives (as span_basis).
    Eigen::MatrixXd v;
  };
  [[nodiscard]] const Span& span(std::size_t skip) const;

  [[nodiscard]] Eigen::Index rows() const { return q_.rows(); }
  // The base's columns factored: those not zero on every row (a column that is adds nothing to any span, and a
  // minimum-norm fit gives it no weight), in the base's order.
  [[nodiscard]] Eigen::Index cols() const { return q_.cols(); }
  [[nodiscard]] const std::vector<Eigen::Index>& columns() const { return columns_; }
  [[nodiscard]] std::size_t groups() const { return ranges_.size(); }
  [[nodiscard]] std::size_t absorbed() const { return absorbed_; }
  [[nodiscard]] const Ranges& ranges(std::size_t group) const { return ranges_[group]; }

  // The groups' products Q_g^T x_g of the set's members, stacked ((members p) x w); x has every row.
  [[nodiscard]] Eigen::MatrixXd products(const Span& s, const Eigen::Ref<const Eigen::MatrixXd>& x) const;
  // x_g -= Q_g c_g on the set's members' rows, c stacked as products() gives them.
  void subtract(const Span& s, const Eigen::Ref<const Eigen::MatrixXd>& c, Eigen::Ref<Eigen::MatrixXd> x) const;

  // Memory held (bytes): the groups' Q and what the row sets' factors hold.
  [[nodiscard]] std::size_t bytes() const;

 private:
  Eigen::MatrixXd q_;                  // n x p: each row the row of its group's Q_g (Householder, thin)
  std::vector<Eigen::MatrixXd> r_;     // per group: p x p, its base rows = Q_g r_g (globally scaled columns)
  std::vector<Eigen::Index> columns_;  // the base's columns factored
  Eigen::VectorXd global_scale_;       // 1 / each factored column's norm over every row
  std::vector<Ranges> ranges_;
  std::size_t absorbed_ = 0;
  mutable std::vector<std::unique_ptr<Span>> spans_;  // per skipped group, the last for every row
};

// Sets every row of the groups' ranges in `ranges` to zero.
void zero_rows(const GroupedBase::Ranges& ranges, Eigen::Ref<Eigen::MatrixXd> x);

}  // namespace guideway::models::explain::engine
