// The weighted least squares of the map's fit (fit_solver.hpp): the groups' normal equations, the solution on chosen
// columns, the groups' variance factors, the functions' columns.
#include "models/map/fit_solver.hpp"

#include <algorithm>
#include <cmath>

namespace guideway::models::map::detail {

using Eigen::Index;
using Eigen::MatrixXd;
using Eigen::VectorXd;

namespace {

MatrixXd sub_matrix(const MatrixXd& m, const std::vector<std::size_t>& cols) {
  MatrixXd out(ix(cols.size()), ix(cols.size()));
  for (std::size_t r = 0; r < cols.size(); ++r)
    for (std::size_t c = 0; c < cols.size(); ++c) out(ix(r), ix(c)) = m(ix(cols[r]), ix(cols[c]));
  return out;
}

}  // namespace

Blocks make_blocks(const MapInputs& in, const ErrorMap& m, const FitOptions& o,
                   const DeadbandWidths& deadbands) {
  Blocks b;
  b.p = m.parameters;
  b.groups = detail::make_groups(in, m, o.ballbar_samples_per_run, deadbands);
  std::size_t next = b.p;
  for (const auto& g : b.groups) {
    b.first_nuisance.push_back(next);
    next += g->nuisance();
    MatrixXd j;
    g->jacobian(m, j);
    VectorXd w(ix(g->rows()));
    for (std::size_t i = 0; i < g->rows(); ++i) w[ix(i)] = 1.0 / (g->sigma[i] * g->sigma[i]);
    b.a.push_back(j.transpose() * w.asDiagonal() * j);
    b.jac.push_back(std::move(j));
    b.w.push_back(std::move(w));
    b.scale2.push_back(1.0);
  }
  b.nu = next - b.p;
  return b;
}

VectorXd local_theta(const Blocks& b, std::size_t g, const VectorXd& theta) {
  const std::size_t local = b.p + b.groups[g]->nuisance();
  VectorXd t(ix(local));
  for (std::size_t k = 0; k < local; ++k) t[ix(k)] = theta[ix(b.global(g, k))];
  return t;
}

std::vector<VectorXd> pseudo_readings(const Blocks& b, ErrorMap& m, const VectorXd& theta) {
  std::vector<double> mp(b.p);
  for (std::size_t k = 0; k < b.p; ++k) mp[k] = theta[ix(k)];
  m.set_parameters(mp);
  std::vector<VectorXd> out;
  for (std::size_t g = 0; g < b.groups.size(); ++g) {
    const Group& gr = *b.groups[g];
    const std::size_t ng = gr.nuisance();
    std::vector<double> nu(ng);
    const VectorXd local = local_theta(b, g, theta);
    for (std::size_t k = 0; k < ng; ++k) nu[k] = local[ix(b.p + k)];
    std::vector<double> f(gr.rows());
    gr.predict(m, nu.data(), f.data());
    VectorXd y(ix(gr.rows()));
    for (std::size_t i = 0; i < gr.rows(); ++i) y[ix(i)] = gr.y[i] - f[i];
    out.push_back(y + b.jac[g] * local);
  }
  return out;
}

Normal normal_of(const Blocks& b, const std::vector<VectorXd>& y, const std::vector<bool>& use_group) {
  Normal out;
  out.n = MatrixXd::Zero(ix(b.columns()), ix(b.columns()));
  out.rhs = VectorXd::Zero(ix(b.columns()));
  for (std::size_t g = 0; g < b.groups.size(); ++g) {
    if (!b.groups[g]->in_fit || (!use_group.empty() && !use_group[g])) continue;
    const double s = 1.0 / b.scale2[g];
    const VectorXd wy = b.w[g].asDiagonal() * y[g];
    const VectorXd c = b.jac[g].transpose() * wy;
    out.yy += s * y[g].dot(wy);
    const std::size_t local = b.p + b.groups[g]->nuisance();
    for (std::size_t r = 0; r < local; ++r) {
      const std::size_t R = b.global(g, r);
      out.rhs[ix(R)] += s * c[ix(r)];
      for (std::size_t q = 0; q < local; ++q) out.n(ix(R), ix(b.global(g, q))) += s * b.a[g](ix(r), ix(q));
    }
  }
  return out;
}

double chi2_on(const Normal& nm, const std::vector<std::size_t>& cols) {
  const MatrixXd n = sub_matrix(nm.n, cols);
  VectorXd rhs(ix(cols.size()));
  for (std::size_t k = 0; k < cols.size(); ++k) rhs[ix(k)] = nm.rhs[ix(cols[k])];
  VectorXd d(n.rows());
  for (Index k = 0; k < n.rows(); ++k) d[k] = n(k, k) > 0 ? 1.0 / std::sqrt(n(k, k)) : 1.0;
  const Eigen::LDLT<MatrixXd> ldlt(d.asDiagonal() * n * d.asDiagonal());
  const VectorXd x = ldlt.solve(d.asDiagonal() * rhs);
  return nm.yy - (d.asDiagonal() * rhs).dot(x);
}

Solution solve(const Blocks& b, const std::vector<VectorXd>& y, const std::vector<std::size_t>& cols,
               const std::vector<bool>& use_group) {
  const Normal nm = normal_of(b, y, use_group);
  const std::size_t n = cols.size();
  const MatrixXd sub = sub_matrix(nm.n, cols);
  VectorXd rhs(ix(n));
  for (std::size_t k = 0; k < n; ++k) rhs[ix(k)] = nm.rhs[ix(cols[k])];
  // Column scaling, then a symmetric eigen-decomposition: a singular direction is dropped, not inverted.
  VectorXd d(ix(n));
  for (std::size_t k = 0; k < n; ++k) d[ix(k)] = sub(ix(k), ix(k)) > 0 ? 1.0 / std::sqrt(sub(ix(k), ix(k))) : 1.0;
  Eigen::SelfAdjointEigenSolver<MatrixXd> eig(d.asDiagonal() * sub * d.asDiagonal());
  const VectorXd ev = eig.eigenvalues();
  const double top = ev.size() ? ev.maxCoeff() : 0.0;
  VectorXd inv_ev(ev.size());
  Solution s;
  for (Index k = 0; k < ev.size(); ++k) {
    inv_ev[k] = ev[k] > 1e-13 * top ? 1.0 / ev[k] : 0.0;
    if (inv_ev[k] == 0.0) ++s.rank_deficiency;
  }
  s.cols = cols;
  s.inverse = d.asDiagonal() * (eig.eigenvectors() * inv_ev.asDiagonal() * eig.eigenvectors().transpose()) *
              d.asDiagonal();
  const VectorXd x = s.inverse * rhs;
  s.theta = VectorXd::Zero(ix(b.columns()));
  for (std::size_t k = 0; k < n; ++k) s.theta[ix(cols[k])] = x[ix(k)];
  std::vector<long> where(b.columns(), -1);
  for (std::size_t k = 0; k < n; ++k) where[cols[k]] = static_cast<long>(k);
  for (std::size_t g = 0; g < b.groups.size(); ++g) {
    const std::size_t local = b.p + b.groups[g]->nuisance();
    const VectorXd r = y[g] - b.jac[g] * local_theta(b, g, s.theta);
    s.chi2.push_back(r.dot(b.w[g].asDiagonal() * r));
    double tr = 0.0;
    if (b.groups[g]->in_fit && (use_group.empty() || use_group[g]))
      for (std::size_t r1 = 0; r1 < local; ++r1) {
        const long R = where[b.global(g, r1)];
        if (R < 0) continue;
        for (std::size_t q = 0; q < local; ++q) {
          const long Q = where[b.global(g, q)];
          if (Q >= 0) tr += s.inverse(R, Q) * b.a[g](ix(q), ix(r1));
        }
      }
    s.trace.push_back(tr / b.scale2[g]);
  }
  return s;
}

void update_scales(Blocks& b, const Solution& s) {
  for (std::size_t g = 0; g < b.groups.size(); ++g) {
    if (!b.groups[g]->in_fit) continue;
    const double dof = std::max(1.0, static_cast<double>(b.groups[g]->rows()) - s.trace[g]);
    b.scale2[g] = std::max(s.chi2[g] / dof, b.groups[g]->stated_sigma ? 1.0 : 1e-12);
  }
}

std::vector<FunctionColumns> function_columns(const ErrorMap& m) {
  std::vector<FunctionColumns> fc;
  for (int j = 0; j < 3; ++j)
    for (int c = 0; c < components; ++c) {
      const ErrorFunction& f = m.function(j, c);
      if (f.first_parameter == no_parameter) continue;
      FunctionColumns col;
      col.axis = j;
      col.component = c;
      col.first = f.first_parameter;
      col.lowest = f.orders.front();
      col.highest = f.orders.back();
      col.chosen = col.highest;
      fc.push_back(col);
    }
  return fc;
}

std::vector<std::size_t> selected_columns(const Blocks& b, const std::vector<FunctionColumns>& fc,
                                          const ErrorMap& m) {
  std::vector<std::size_t> cols;
  for (const auto& f : fc)
    for (int k = f.lowest; k <= f.chosen; ++k) cols.push_back(f.first + static_cast<std::size_t>(k - f.lowest));
  for (const auto& q : m.squareness)
    if (q.parameter != no_parameter) cols.push_back(q.parameter);
  for (std::size_t k = b.p; k < b.columns(); ++k) cols.push_back(k);
  std::sort(cols.begin(), cols.end());
  return cols;
}

}  // namespace guideway::models::map::detail
