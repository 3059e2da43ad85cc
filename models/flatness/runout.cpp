// The spindle's squareness to the cross carriage from a run-out revolution (runout.hpp; Mu 2012, Eq. 21).
#include "models/flatness/runout.hpp"

#include <cmath>
#include <limits>
#include <numbers>
#include <sstream>

#include <Eigen/Dense>

#include "core/number_format.hpp"
#include "core/csv_table.hpp"
#include "results/session_kinds.hpp"

namespace guideway::models::flatness {

namespace {

}  // namespace

RunoutRevolution parse_runout_revolution(std::string_view text, const std::string& source) {
  const CsvTable t = parse_csv_table(text, source);
  RunoutRevolution rev;
  rev.source = source;
  // The metadata within the runout session's ranges of the same options (results/session_kinds.hpp).
  const auto in = [&](const results::SessionOption& o, std::string_view what) {
    return t.optional_metadata_in(std::string(o.name), o.min, o.max, what);
  };
  const auto required = [&](const results::SessionOption& o, std::string_view what) {
    return t.metadata_in(std::string(o.name), o.min, o.max, what);
  };
  rev.plate_diameter_m = required(results::runout_plate_diameter_mm, "mm, a thrust plate's diameter") * 1e-3;
  rev.parallelism_m = required(results::runout_parallelism_um, "um, a plate's parallelism") * 1e-6;
  rev.u_parallelism_m = in(results::runout_parallelism_u_um, "um, its standard uncertainty").value_or(0.0) * 1e-6;
  if (auto travel = in(results::runout_travel_mm, "mm, a machine's travel")) {
    if (!(*travel > 0)) throw CsvError(source + ": travel_mm = " + significant_digits(*travel, 10) + " must be positive");
    rev.travel_m = *travel * 1e-3;
  }
  if (auto turned = t.optional_metadata_in("artifact_turned_deg", -360.0, 360.0, "deg, a turn of the artifact")) {
    rev.artifact_turned_rad = *turned * std::numbers::pi / 180.0;
  }
  if (const auto zero = t.metadata.find("angle_zero"); zero != t.metadata.end()) {
    if (zero->second != "spindle" && zero->second != "first_reading")
      throw CsvError(source + ": angle_zero = " + zero->second.substr(0, 80) +
                     ": 'spindle' (angles from the spindle's zero) or 'first_reading'");
    rev.angle_from_spindle_zero = zero->second == "spindle";
  }
  const std::size_t ca = t.column("angle_deg");
  const std::size_t cr = t.column("runout_um");
  const double max_deg = 360.0 * (results::runout_revolutions.max + 1);
  for (const auto& row : t.rows) {
    rev.angle_rad.push_back(t.number_in(row, ca, -max_deg, max_deg, "deg, the session's most revolutions") *
                            std::numbers::pi / 180.0);
    rev.runout_m.push_back(t.number_in(row, cr, -runout_max_abs_um, runout_max_abs_um,
                                       "um, a micrometer's range (10 mm)") *
                           1e-6);
    rev.line.push_back(row.line);
  }
  if (rev.angle_rad.size() < 8)
    throw CsvError(source + ": " + std::to_string(rev.angle_rad.size()) +
                     " samples; a run-out revolution needs at least 8");
  return rev;
}

RunoutRevolution read_runout_revolution(const std::string& path) {
  return parse_runout_revolution(read_text_file(path), path);
}

RunoutResult identify_runout(const RunoutRevolution& rev) {
  const auto n = static_cast<Eigen::Index>(rev.angle_rad.size());
  if (n < 8) throw CsvError(rev.source + ": a run-out revolution needs at least 8 samples");
  // z = c + a1 cos + b1 sin + a2 cos 2 + b2 sin 2, columns scaled alike (all O(1)).
  Eigen::MatrixXd j(n, 5);
  Eigen::VectorXd y(n);
  for (Eigen::Index k = 0; k < n; ++k) {
    const double phi = rev.angle_rad[static_cast<std::size_t>(k)];
    j.row(k) << 1.0, std::cos(phi), std::sin(phi), std::cos(2 * phi), std::sin(2 * phi);
    y(k) = rev.runout_m[static_cast<std::size_t>(k)];
  }
  Eigen::JacobiSVD<Eigen::MatrixXd> svd(j);
  const auto& sv = svd.singularValues();
  RunoutResult r;
  r.samples = static_cast<std::size_t>(n);
  r.condition_number = sv(4) > 0 ? sv(0) / sv(4) : std::numeric_limits<double>::infinity();
  if (!(r.condition_number < 1e6))
    throw CsvError(rev.source + ": the angles (" + std::to_string(n) +
                     " samples) do not determine a once- and twice-per-revolution sine (condition number " +
                     significant_digits(r.condition_number, 10) + "); record a full revolution");
  const Eigen::VectorXd p = j.colPivHouseholderQr().solve(y);
  const Eigen::VectorXd res = y - j * p;
  const double s2 = res.squaredNorm() / static_cast<double>(n - 5);
  const Eigen::MatrixXd cov = s2 * (j.transpose() * j).inverse();
  r.offset_m = p(0);
  const double a = p(1), b = p(2);
  r.amplitude_m = std::hypot(a, b);
  r.phase_rad = std::atan2(b, a);
  if (r.phase_rad < 0) r.phase_rad += 2 * std::numbers::pi;
  // First-order propagation through A = hypot(a, b), phase = atan2(b, a).
  if (r.amplitude_m > 0) {
    const Eigen::Vector2d ga(a / r.amplitude_m, b / r.amplitude_m);
    const Eigen::Vector2d gp(-b / (r.amplitude_m * r.amplitude_m), a / (r.amplitude_m * r.amplitude_m));
    const Eigen::Matrix2d c = cov.block<2, 2>(1, 1);
    r.u_amplitude_m = std::sqrt(ga.dot(c * ga));
    r.u_phase_rad = std::sqrt(gp.dot(c * gp));
  } else {
    r.u_amplitude_m = std::sqrt(0.5 * (cov(1, 1) + cov(2, 2)));
    r.u_phase_rad = std::numbers::pi;
  }
  r.second_harmonic_m = std::hypot(p(3), p(4));
  r.residual_rms_m = std::sqrt(res.squaredNorm() / static_cast<double>(n));
  r.runout_m = 2 * r.amplitude_m;
  r.u_runout_m = 2 * r.u_amplitude_m;
  r.parallelism_m = rev.parallelism_m;
  r.plate_diameter_m = rev.plate_diameter_m;
  r.deflection_rad = (r.runout_m + rev.parallelism_m) / rev.plate_diameter_m;
  r.u_deflection_rad = std::hypot(r.u_runout_m, rev.u_parallelism_m) / rev.plate_diameter_m;
  if (rev.travel_m) {
    r.travel_m = rev.travel_m;
    r.squareness_amplitude_m = r.deflection_rad * *rev.travel_m;
    r.u_squareness_amplitude_m = r.u_deflection_rad * *rev.travel_m;
  }
  return r;
}

}  // namespace guideway::models::flatness
