// Volumetric accuracy of an error map (volumetric.hpp): the tool point's error vector over a grid of the working
// volume.
#include "models/map/volumetric.hpp"

#include <algorithm>
#include <cmath>
#include <random>

#include <Eigen/Dense>

namespace guideway::models::map {

namespace {

using Eigen::Index;
using Eigen::MatrixXd;
using Eigen::VectorXd;

Index ix(std::size_t i) { return static_cast<Index>(i); }

struct Largest {
  double length = -1.0;
  std::size_t at = 0;
};

Largest largest(const std::vector<Vec3>& e) {
  Largest l;
  for (std::size_t i = 0; i < e.size(); ++i) {
    const double n = std::sqrt(e[i][0] * e[i][0] + e[i][1] * e[i][1] + e[i][2] * e[i][2]);
    if (n > l.length) l = {n, i};
  }
  return l;
}

}  // namespace

std::string volumetric_definition() {
  return "largest length of the tool point's error vector over the grid, after the least-squares rigid-body "
         "translation and rotation of the volume (a workpiece's set-up) is taken out; E_VX, E_VY, E_VZ are the "
         "ranges of its components (ISO 230-1:2012 volumetric performance, ISO/TR 16907)";
}

std::vector<Vec3> volume_grid(const std::array<Travel, 3>& travel, const std::array<std::size_t, 3>& points) {
  std::vector<Vec3> out;
  const auto at = [&](std::size_t a, std::size_t k) {
    const Travel& t = travel[a];
    return points[a] < 2 ? 0.5 * (t.lo_m + t.hi_m)
                         : t.lo_m + t.length_m() * static_cast<double>(k) / static_cast<double>(points[a] - 1);
  };
  for (std::size_t kz = 0; kz < std::max<std::size_t>(points[2], 1); ++kz)
    for (std::size_t ky = 0; ky < std::max<std::size_t>(points[1], 1); ++ky)
      for (std::size_t kx = 0; kx < std::max<std::size_t>(points[0], 1); ++kx)
        out.push_back({at(0, kx), at(1, ky), at(2, kz)});
  return out;
}

std::vector<Vec3> relative_to_rigid_body(const std::vector<Vec3>& at, const std::vector<Vec3>& error, Vec3* translation,
                                         Vec3* rotation) {
  const std::size_t n = at.size();
  Vec3 c{};
  for (const auto& p : at)
    for (std::size_t i = 0; i < 3; ++i) c[i] += p[i] / static_cast<double>(n);
  // error ~ t + w x (p - c) = t - [r]x w: rows per point.
  Eigen::Matrix<double, 6, 6> nm = Eigen::Matrix<double, 6, 6>::Zero();
  Eigen::Matrix<double, 6, 1> rhs = Eigen::Matrix<double, 6, 1>::Zero();
  const auto rows = [&](std::size_t i) {
    const double r0 = at[i][0] - c[0], r1 = at[i][1] - c[1], r2 = at[i][2] - c[2];
    Eigen::Matrix<double, 3, 6> b;
    b << 1, 0, 0, 0, r2, -r1,  //
        0, 1, 0, -r2, 0, r0,   //
        0, 0, 1, r1, -r0, 0;
    return b;
  };
  for (std::size_t i = 0; i < n; ++i) {
    const auto b = rows(i);
    const Eigen::Vector3d e(error[i][0], error[i][1], error[i][2]);
    nm += b.transpose() * b;
    rhs += b.transpose() * e;
  }
  const Eigen::Matrix<double, 6, 1> x = nm.completeOrthogonalDecomposition().solve(rhs);
  if (translation) *translation = {x[0], x[1], x[2]};
  if (rotation) *rotation = {x[3], x[4], x[5]};
  std::vector<Vec3> out(n);
  for (std::size_t i = 0; i < n; ++i) {
    const Eigen::Vector3d fit = rows(i) * x;
    for (std::size_t k = 0; k < 3; ++k) out[i][k] = error[i][k] - fit[ix(k)];
  }
  return out;
}

VolumetricAccuracy field_accuracy(const std::vector<Vec3>& at, const std::vector<Vec3>& error) {
  VolumetricAccuracy v;
  v.points = at.size();
  if (at.empty()) return v;
  const std::vector<Vec3> rel = relative_to_rigid_body(at, error, &v.rigid_translation_m, &v.rigid_rotation_rad);
  const Largest l = largest(rel);
  v.value_m = l.length;
  v.at_m = at[l.at];
  v.error_at_m = rel[l.at];
  double ss = 0;
  for (std::size_t k = 0; k < 3; ++k) {
    double lo = rel[0][k], hi = rel[0][k];
    for (const auto& e : rel) {
      lo = std::min(lo, e[k]);
      hi = std::max(hi, e[k]);
    }
    v.component_range_m[k] = hi - lo;
  }
  for (const auto& e : rel) ss += e[0] * e[0] + e[1] * e[1] + e[2] * e[2];
  v.rms_m = std::sqrt(ss / static_cast<double>(rel.size()));
  return v;
}

VolumetricAccuracy volumetric_accuracy(const ErrorMap& map, const VolumetricOptions& o) {
  const Vec3 tool = o.tool_offset_m.value_or(map.tool_offset_m);
  const std::vector<Vec3> at = volume_grid(map.travel, o.points);
  std::vector<Vec3> e(at.size());
  for (std::size_t i = 0; i < at.size(); ++i) e[i] = tool_error(map, at[i], tool);
  VolumetricAccuracy v = field_accuracy(at, e);
  v.tool_offset_m = tool;
  for (const auto& axis : map.functions)
    for (const auto& f : axis)
      if (!f.determined) v.missing.push_back(function_name(f.axis, f.component));
  const char* q_names[] = {"squareness xy", "squareness xz", "squareness yz"};
  for (std::size_t i = 0; i < 3; ++i)
    if (!map.squareness[i].determined) v.missing.push_back(q_names[i]);
  const std::size_t p = map.parameters;
  if (map.covariance.size() != p * p || p == 0 || o.draws < 2) return v;

  // Drawn maps, to first order about this one: e + J d, d ~ N(0, covariance).
  MatrixXd j(ix(3 * at.size()), ix(p));
  std::vector<double> rows(3 * p);
  for (std::size_t i = 0; i < at.size(); ++i) {
    tool_error_jacobian(map, at[i], tool, rows.data());
    for (std::size_t r = 0; r < 3; ++r)
      for (std::size_t k = 0; k < p; ++k) j(ix(3 * i + r), ix(k)) = rows[r * p + k];
  }
  MatrixXd cov(ix(p), ix(p));
  for (std::size_t a = 0; a < p; ++a)
    for (std::size_t b = 0; b < p; ++b) cov(ix(a), ix(b)) = map.covariance[a * p + b];
  Eigen::SelfAdjointEigenSolver<MatrixXd> eig(0.5 * (cov + cov.transpose()));
  const VectorXd sd = eig.eigenvalues().cwiseMax(0.0).cwiseSqrt();
  const MatrixXd root = eig.eigenvectors() * sd.asDiagonal();
  std::mt19937_64 rng(o.seed);
  std::normal_distribution<double> g(0.0, 1.0);
  std::vector<double> figures;
  std::vector<Vec3> drawn(at.size());
  for (std::size_t k = 0; k < o.draws; ++k) {
    VectorXd z(ix(p));
    for (std::size_t a = 0; a < p; ++a) z[ix(a)] = g(rng);
    const VectorXd de = j * (root * z);
    for (std::size_t i = 0; i < at.size(); ++i)
      for (std::size_t r = 0; r < 3; ++r) drawn[i][r] = e[i][r] + de[ix(3 * i + r)];
    figures.push_back(largest(relative_to_rigid_body(at, drawn)).length);
  }
  double mean = 0;
  for (double f : figures) mean += f / static_cast<double>(figures.size());
  double var = 0;
  for (double f : figures) var += (f - mean) * (f - mean) / static_cast<double>(figures.size() - 1);
  v.u_spread_m = std::sqrt(var);
  v.u_bias_m = mean - v.value_m;
  v.u_m = std::sqrt(var + v.u_bias_m * v.u_bias_m);
  return v;
}

}  // namespace guideway::models::map
