#pragma once
// EXPLAIN's least squares on tall designs (models/explain/engine): the triangular factor of a tall matrix in
// one pass (tall_r), an orthonormal basis of a design's span with the rank a column-pivoted QR decides
// (span_basis), and a held-out prediction from a fit to the training rows (predict, predict_beside). Columns
// are scaled to unit norm first: a design mixes units. Pure functions; thread safe.

#include <functional>
#include <vector>

#include <Eigen/Core>

namespace guideway::models::explain::engine {

// A direction whose pivot is below this fraction of the largest (columns scaled to unit norm, as
// solve_lsq's rank analysis) adds no rank.
inline constexpr double rank_tolerance = 1e-9;

// The triangular factor of a tall matrix [a y] (y optional: a vector or none), R with R^T R = [a y]^T [a y],
// p + (y ? 1 : 0) rows.
Eigen::MatrixXd tall_r(const Eigen::Ref<const Eigen::MatrixXd>& a, const Eigen::VectorXd* y = nullptr);
// The same of an n x w matrix never held whole: `fill(from, part)` writes its rows [from, from + part.rows()) (a
// chunk that fits in a core's cache), for a design whose columns are made as they are read.
using RowFiller = std::function<void(Eigen::Index from, Eigen::Ref<Eigen::MatrixXd> part)>;
Eigen::MatrixXd tall_r_rows(Eigen::Index n, Eigen::Index w, const RowFiller& fill);

// y's least-squares fit on some of a design's columns, from the triangular factor r of [design y] (tall_r, y its
// last column): the residual sum of squares and the rank, the columns scaled to unit norm and the rank decided as
// span_basis decides it (R's columns have the design's norms and products). A subset of a few columns costs a QR of
// r's rows, not a pass over the samples.
struct ColumnsFit {
  double rss = 0;
  Eigen::Index rank = 0;
};
ColumnsFit fit_of_columns(const Eigen::MatrixXd& r, const std::vector<Eigen::Index>& columns);

// Each column scaled to unit norm (a zero column kept); the scales applied.
Eigen::VectorXd scale_columns(Eigen::Ref<Eigen::MatrixXd> m);

// The minimum-norm solution of S b = y from the triangular factor r of [S y] (p + 1 columns).
Eigen::VectorXd min_norm_solution(const Eigen::MatrixXd& r, Eigen::Index p);

// The held-out rows' prediction (jh: their columns) from a least-squares fit to the training rows (jt, yt):
// the minimum-norm solution of the column-scaled problem. False when the fit fails.
bool predict(Eigen::MatrixXd jt, const Eigen::VectorXd& yt, const Eigen::MatrixXd& jh, Eigen::VectorXd& out);

// A fold's base on its training rows, factored once: every held-out fit in that fold has the base's columns
// and differs only in the few columns of the effects beside it.
struct FoldBase {
  Eigen::VectorXd scale;  // predict()'s column scales
  Eigen::MatrixXd q, r;   // the scaled base = Q R, Q's columns orthonormal (Householder: whatever the base's rank)
};
FoldBase fold_base(Eigen::MatrixXd b);

// predict() of the design [base rest] from the fold's factored base. jh: the held-out rows of the base's
// columns then rest's.
bool predict_beside(const FoldBase& base, Eigen::MatrixXd rest, const Eigen::VectorXd& yt, const Eigen::MatrixXd& jh,
                    Eigen::VectorXd& out);

// An orthonormal basis of the span of s's columns (each scaled to unit norm first), of the rank a
// column-pivoted QR with threshold rank_tolerance gives.
Eigen::MatrixXd span_basis(Eigen::MatrixXd s);
// The same of columns already scaled, a direction counted where its pivot is above rank_tolerance itself (for
// columns projected off a span they were of unit norm before: the threshold a joint pivoted QR of them with that
// span's columns would apply).
Eigen::MatrixXd unit_span_basis(Eigen::MatrixXd s);

}  // namespace guideway::models::explain::engine
