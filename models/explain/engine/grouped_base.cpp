// The base of a problem factored group by group (grouped_base.hpp).
#include "models/explain/engine/grouped_base.hpp"

#include <algorithm>

#include <Eigen/QR>

#include "models/explain/engine/subspace.hpp"

namespace guideway::models::explain::engine {

GroupedBase::GroupedBase(const Eigen::MatrixXd& base, const std::vector<int>& group_of, std::size_t groups,
                         std::size_t absorbed)
    : r_(groups), ranges_(groups), absorbed_(absorbed), spans_(groups + 1) {
  // Every row has a group; a problem without a base may give its base no rows.
  const auto n = static_cast<Eigen::Index>(group_of.size());
  std::vector<double> norms;
  for (Eigen::Index c = 0; c < base.cols(); ++c)
    if (const double norm = base.col(c).norm(); norm > 0) {
      columns_.push_back(c);
      norms.push_back(norm);
    }
  const auto p = static_cast<Eigen::Index>(columns_.size());
  q_ = Eigen::MatrixXd::Zero(n, p);
  global_scale_.resize(p);
  for (Eigen::Index i = 0; i < n;) {
    const int g = group_of[static_cast<std::size_t>(i)];
    Eigen::Index e = i + 1;
    while (e < n && group_of[static_cast<std::size_t>(e)] == g) ++e;
    ranges_[static_cast<std::size_t>(g)].emplace_back(i, e);
    i = e;
  }
  // Columns scaled to unit norm over every row first: the base mixes units (Householder QR does not care in exact
  // arithmetic, its rounding does).
  for (Eigen::Index c = 0; c < p; ++c) global_scale_[c] = 1.0 / norms[static_cast<std::size_t>(c)];
  for (std::size_t g = 0; g < groups; ++g) {
    r_[g] = Eigen::MatrixXd::Zero(p, p);
    Eigen::Index rows = 0;
    for (const auto& [a, e] : ranges_[g]) rows += e - a;
    if (rows == 0 || p == 0) continue;
    Eigen::MatrixXd b(rows, p);
    Eigen::Index at = 0;
    for (const auto& [a, e] : ranges_[g]) {
      b.middleRows(at, e - a) = base(Eigen::seqN(a, e - a), columns_) * global_scale_.asDiagonal();
      at += e - a;
    }
    const Eigen::Index k = std::min(rows, p);
    const Eigen::HouseholderQR<Eigen::MatrixXd> h(b);
    r_[g].topRows(k) = h.matrixQR().topRows(k).triangularView<Eigen::Upper>();
    const Eigen::MatrixXd q = h.householderQ() * Eigen::MatrixXd::Identity(rows, k);
    at = 0;
    for (const auto& [a, e] : ranges_[g]) {
      q_.block(a, 0, e - a, k) = q.middleRows(at, e - a);
      at += e - a;
    }
  }
}

const GroupedBase::Span& GroupedBase::span(std::size_t skip) const {
  auto& slot = spans_[skip == all ? ranges_.size() : skip];
  if (slot) return *slot;
  auto s = std::make_unique<Span>();
  const Eigen::Index p = cols();
  for (std::size_t g = 0; g < ranges_.size(); ++g) {
    if (g == skip || ranges_[g].empty()) continue;
    s->members.push_back(g);
    for (const auto& [a, e] : ranges_[g]) s->rows += e - a;
  }
  const auto m = static_cast<Eigen::Index>(s->members.size());
  s->scale = Eigen::VectorXd::Ones(p);
  if (p == 0 || m == 0) {
    s->w = Eigen::MatrixXd(m * p, 0);
    s->r = Eigen::MatrixXd(0, 0);
    s->v = Eigen::MatrixXd(m * p, 0);
    return *(slot = std::move(s));
  }
  Eigen::MatrixXd stacked(m * p, p);
  for (Eigen::Index k = 0; k < m; ++k) stacked.middleRows(k * p, p) = r_[s->members[static_cast<std::size_t>(k)]];
  const Eigen::HouseholderQR<Eigen::MatrixXd> h(stacked);
  s->w = h.householderQ() * Eigen::MatrixXd::Identity(m * p, p);
  s->r = h.matrixQR().topRows(p).triangularView<Eigen::Upper>();
  // The columns scaled to unit norm on the set's rows, as predict() and span_basis scale a design.
  for (Eigen::Index c = 0; c < p; ++c) {
    const double norm = s->r.col(c).norm();
    if (norm > 0) {
      s->r.col(c) /= norm;
      s->scale[c] = global_scale_[c] / norm;
    }
  }
  Eigen::ColPivHouseholderQR<Eigen::MatrixXd> qr(s->r);
  qr.setThreshold(rank_tolerance);
  s->v = s->w * (qr.householderQ() * Eigen::MatrixXd::Identity(p, qr.rank()));
  return *(slot = std::move(s));
}

Eigen::MatrixXd GroupedBase::products(const Span& s, const Eigen::Ref<const Eigen::MatrixXd>& x) const {
  const Eigen::Index p = cols();
  Eigen::MatrixXd out = Eigen::MatrixXd::Zero(static_cast<Eigen::Index>(s.members.size()) * p, x.cols());
  for (std::size_t k = 0; k < s.members.size(); ++k)
    for (const auto& [a, e] : ranges_[s.members[k]])
      out.middleRows(static_cast<Eigen::Index>(k) * p, p).noalias() +=
          q_.middleRows(a, e - a).transpose() * x.middleRows(a, e - a);
  return out;
}

void GroupedBase::subtract(const Span& s, const Eigen::Ref<const Eigen::MatrixXd>& c,
                           Eigen::Ref<Eigen::MatrixXd> x) const {
  const Eigen::Index p = cols();
  for (std::size_t k = 0; k < s.members.size(); ++k)
    for (const auto& [a, e] : ranges_[s.members[k]])
      x.middleRows(a, e - a).noalias() -= q_.middleRows(a, e - a) * c.middleRows(static_cast<Eigen::Index>(k) * p, p);
}

std::size_t GroupedBase::bytes() const {
  std::size_t doubles = static_cast<std::size_t>(q_.size());
  for (const auto& r : r_) doubles += static_cast<std::size_t>(r.size());
  for (const auto& s : spans_)
    if (s) doubles += static_cast<std::size_t>(s->w.size() + s->r.size() + s->v.size());
  return doubles * sizeof(double);
}

void zero_rows(const GroupedBase::Ranges& ranges, Eigen::Ref<Eigen::MatrixXd> x) {
  if (x.cols() == 0) return;  // no column: nothing to zero, and a block of its null data would offset a null pointer
  for (const auto& [a, e] : ranges) x.middleRows(a, e - a).setZero();
}

}  // namespace guideway::models::explain::engine
