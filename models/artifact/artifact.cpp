// Six error motions of a linear axis from a 1-D artifact (artifact.hpp; Wei et al. 2019): each placement's readings
// fitted with their uncertainties.
#include "models/artifact/artifact.hpp"

#include <array>
#include <cmath>
#include <numbers>

#include "core/csv_table.hpp"
#include "core/units.hpp"

namespace guideway::models::artifact {

namespace {


const char* placement_name(ArtifactPlacement p) {
  switch (p) {
    case ArtifactPlacement::calibration:
      return "calibration";
    case ArtifactPlacement::horizontal:
      return "horizontal";
    case ArtifactPlacement::vertical:
      return "vertical";
  }
  return "?";
}

std::string at_line(const std::string& source, std::size_t line) { return source + ":" + std::to_string(line) + ": "; }

std::size_t required_column(const CsvTable& t, const std::string& name) {
  if (auto c = t.find_column(name)) return *c;
  throw CsvError(at_line(t.source, t.header_line) + "missing column '" + name + "'");
}

// The plausible ranges of the format (docs/formats.md, "1-D artifact"): a camera's image, a machine's
// travel, a tilt the sensor can see; a conversion factor and an uncertainty of at most 1000 of their unit.
constexpr double max_factor = 1000.0;
constexpr double max_abs_px = 1e5;
constexpr double max_abs_mm = 1e5;
constexpr double max_abs_arcsec = 36000.0;

double positive_meta(const CsvTable& t, const std::string& key) {
  const double v = t.metadata_in(key, 0.0, max_factor, "(a conversion factor of the sensor)");
  if (!(v > 0)) throw CsvError(t.source + ": metadata '" + key + "' must be positive");
  return v;
}

double optional_non_negative(const CsvTable& t, const std::string& key, double fallback) {
  return t.optional_metadata_in(key, 0.0, max_factor, "(a standard uncertainty)").value_or(fallback);
}

double px(const CsvTable& t, const CsvTable::Row& row, std::size_t col) {
  return t.number_in(row, col, -max_abs_px, max_abs_px, "px, a camera's image");
}

double mm(const CsvTable& t, const CsvTable::Row& row, std::size_t col) {
  return t.number_in(row, col, -max_abs_mm, max_abs_mm, "mm, a machine's travel");
}

// Values of one identification, without uncertainties (linear, or bilinear in k and m, in every input).
struct Values {
  ArtifactPlacementValues c, h, v;
  std::vector<ArtifactTargetErrors> e;
};

Values compute(const ArtifactReadings& c, const ArtifactReadings& h, const ArtifactReadings& v, double k, double m,
               bool coupling) {
  Values out{placement_values(c, k, m), placement_values(h, k, m), placement_values(v, k, m), {}};
  const double km = coupling ? k * m : 0.0;
  for (std::size_t i = 0; i < c.target.size(); ++i) {
    ArtifactTargetErrors e;
    e.target = c.target[i];
    e.x_m = h.along_m[i];
    // Angles: machine - calibration (Wei's epsilon_x, epsilon_y; epsilon_z from the vertical placement).
    e.ex_rad = out.h.theta_x_rad[i] - out.c.theta_x_rad[i];
    e.ey_rad = out.h.theta_y_rad[i] - out.c.theta_y_rad[i];
    e.ez_rad = out.v.theta_y_rad[i] - out.c.theta_y_rad[i];
    e.ex_vertical_rad = out.v.theta_x_rad[i] - out.c.theta_x_rad[i];
    // Positions: delta = X'_F - X_F - k m epsilon (the coupling of the sensor's tilt into the paraboloid
    // spot, taken with the tilt of the same placement); the tool's error is -delta.
    // (0 - x, not -x: the reference target reads 0, not -0.)
    e.dx_m = 0.0 - (out.h.X_F_m[i] - out.c.X_F_m[i] - km * e.ey_rad);
    e.dy_m = 0.0 - (out.h.Y_F_m[i] - out.c.Y_F_m[i] - km * e.ex_rad);
    e.dz_m = 0.0 - (out.v.Y_F_m[i] - out.c.Y_F_m[i] - km * e.ex_vertical_rad);
    out.e.push_back(e);
  }
  return out;
}

std::array<double, 7> outputs(const ArtifactTargetErrors& e) {
  return {e.dx_m, e.dy_m, e.dz_m, e.ex_rad, e.ey_rad, e.ez_rad, e.ex_vertical_rad};
}

}  // namespace

int across_axis(int axis, ArtifactPlacement placement) {
  if (placement == ArtifactPlacement::vertical) return axis == 2 ? 1 : 2;
  return axis == 0 ? 1 : 0;
}

MachineErrors machine_errors(const ArtifactTargetErrors& e, int axis) {
  MachineErrors m;
  const auto h = static_cast<std::size_t>(across_axis(axis, ArtifactPlacement::horizontal));
  const auto v = static_cast<std::size_t>(across_axis(axis, ArtifactPlacement::vertical));
  const auto j = static_cast<std::size_t>(axis);
  m.d[j] = e.dx_m;
  m.u_d[j] = e.u_dx_m;
  m.d[h] = e.dy_m;
  m.u_d[h] = e.u_dy_m;
  m.d[v] = e.dz_m;
  m.u_d[v] = e.u_dz_m;
  m.r[j] = e.ex_rad;
  m.u_r[j] = e.u_ex_rad;
  m.r[h] = e.ey_rad;
  m.u_r[h] = e.u_ey_rad;
  m.r[v] = e.ez_rad;
  m.u_r[v] = e.u_ez_rad;
  return m;
}

ArtifactReadings parse_artifact_readings(std::string_view text, const std::string& source, ArtifactPlacement expected) {
  const CsvTable t = parse_csv_table(text, source);
  ArtifactReadings r;
  r.source = source;
  const auto p = t.metadata.find("placement");
  if (p == t.metadata.end())
    throw CsvError(source + ": missing metadata line '# placement = " + placement_name(expected) + "'");
  if (p->second != placement_name(expected))
    throw CsvError(source + ": placement is '" + p->second + "', expected '" + placement_name(expected) + "'");
  r.placement = expected;
  if (expected == ArtifactPlacement::calibration) {
    if (t.metadata.count("k_um_per_px") != 0) r.k_m_per_px = positive_meta(t, "k_um_per_px") * 1e-6;
    if (t.metadata.count("m_px_per_arcsec") != 0) r.m_px_per_rad = positive_meta(t, "m_px_per_arcsec") / rad_per_arcsec;
    r.u_k_m_per_px = optional_non_negative(t, "u_k_um_per_px", 0.0) * 1e-6;
    r.u_m_px_per_rad = optional_non_negative(t, "u_m_px_per_arcsec", 0.0) / rad_per_arcsec;
  }
  r.u_spot_px = optional_non_negative(t, "u_spot_px", 0.1);
  r.u_position_m = optional_non_negative(t, "u_position_um", 0.0) * 1e-6;
  if (const auto a = t.metadata.find("axis"); a != t.metadata.end()) {
    if (a->second != "x" && a->second != "y" && a->second != "z")
      throw CsvError(source + ": axis is '" + a->second + "', expected x, y or z");
    r.axis = a->second[0] - 'x';
  }
  const auto column_of = [](int axis) { return std::string(1, "XYZ"[axis]) + "_M_mm"; };
  const std::size_t c_target = required_column(t, "target");
  const std::size_t c_along = required_column(t, column_of(r.axis));
  const std::size_t c_across = required_column(t, column_of(across_axis(r.axis, expected)));
  const std::size_t c_xm = required_column(t, "x_M_px");
  const std::size_t c_ym = required_column(t, "y_M_px");
  const std::size_t c_xf = required_column(t, "x_F_px");
  const std::size_t c_yf = required_column(t, "y_F_px");
  for (const auto& row : t.rows) {
    const double id = t.number(row, c_target);
    const auto want = static_cast<double>(r.target.size());
    if (id != want)
      throw CsvError(at_line(source, row.line) + "target " + std::string(t.cell(row, c_target)) + ", expected " +
                     std::to_string(r.target.size()) +
                     " (targets are numbered 0, 1, 2, ... in order; 0 is the "
                     "reference)");
    r.target.push_back(static_cast<int>(id));
    r.along_m.push_back(mm(t, row, c_along) * 1e-3);
    r.across_m.push_back(mm(t, row, c_across) * 1e-3);
    r.x_M_px.push_back(px(t, row, c_xm));
    r.y_M_px.push_back(px(t, row, c_ym));
    r.x_F_px.push_back(px(t, row, c_xf));
    r.y_F_px.push_back(px(t, row, c_yf));
    r.line.push_back(row.line);
  }
  if (r.target.size() < 2)
    throw CsvError(source + ": " + std::to_string(r.target.size()) + " targets; need at least 2");
  return r;
}

namespace {

// Straight line spot = c + slope * reference through a scan file; returns the fit with slope's u.
ConversionFit fit_scan(std::string_view text, const std::string& source, const char* kind, const char* ref_col,
                       const char* spot_col, double ref_scale) {
  const CsvTable t = parse_csv_table(text, source);
  const auto s = t.metadata.find("scan");
  if (s == t.metadata.end()) throw CsvError(source + ": missing metadata line '# scan = " + kind + "'");
  if (s->second != kind) throw CsvError(source + ": scan is '" + s->second + "', expected '" + kind + "'");
  const std::size_t cr = required_column(t, ref_col);
  const std::size_t cs = required_column(t, spot_col);
  const std::size_t n = t.rows.size();
  if (n < 3) throw CsvError(source + ": " + std::to_string(n) + " points; a scan needs at least 3");
  std::vector<double> x(n), y(n);
  double xm = 0, ym = 0;
  for (std::size_t i = 0; i < n; ++i) {
    const bool displacement = std::string_view(kind) == "displacement";
    x[i] = (displacement ? mm(t, t.rows[i], cr)
                         : t.number_in(t.rows[i], cr, -max_abs_arcsec, max_abs_arcsec, "arcsec, a tilt of 10 deg")) *
           ref_scale;
    y[i] = px(t, t.rows[i], cs);
    xm += x[i];
    ym += y[i];
  }
  xm /= static_cast<double>(n);
  ym /= static_cast<double>(n);
  double sxx = 0, sxy = 0;
  for (std::size_t i = 0; i < n; ++i) {
    sxx += (x[i] - xm) * (x[i] - xm);
    sxy += (x[i] - xm) * (y[i] - ym);
  }
  if (!(sxx > 0)) throw CsvError(source + ": column '" + ref_col + "' does not change; nothing to fit");
  ConversionFit f;
  f.source = source;
  f.points = n;
  f.slope = sxy / sxx;
  f.intercept_px = ym - f.slope * xm;
  double rss = 0;
  for (std::size_t i = 0; i < n; ++i) {
    const double r = y[i] - f.intercept_px - f.slope * x[i];
    rss += r * r;
  }
  f.residual_rms_px = std::sqrt(rss / static_cast<double>(n));
  f.u_slope = std::sqrt(rss / static_cast<double>(n - 2) / sxx);
  if (!(f.slope != 0)) throw CsvError(source + ": the spot does not move with '" + ref_col + "'");
  return f;
}

}  // namespace

ConversionFit fit_k_scan(std::string_view text, const std::string& source) {
  ConversionFit f = fit_scan(text, source, "displacement", "X_M_mm", "x_M_px", 1e-3);
  f.coefficient = 1.0 / f.slope;  // x_M = c + X_M / k
  f.u = f.u_slope / (f.slope * f.slope);
  return f;
}

ConversionFit fit_m_scan(std::string_view text, const std::string& source) {
  ConversionFit f = fit_scan(text, source, "angle", "theta_arcsec", "x_F_px", rad_per_arcsec);
  f.coefficient = f.slope;  // x_F = c + m theta
  f.u = f.u_slope;
  return f;
}

ConversionFit read_k_scan(const std::string& path) { return fit_k_scan(read_text_file(path), path); }
ConversionFit read_m_scan(const std::string& path) { return fit_m_scan(read_text_file(path), path); }

ArtifactReadings read_artifact_readings(const std::string& path, ArtifactPlacement expected) {
  return parse_artifact_readings(read_text_file(path), path, expected);
}

ArtifactPlacementValues placement_values(const ArtifactReadings& r, double k, double m) {
  ArtifactPlacementValues v;
  const std::size_t n = r.target.size();
  for (std::size_t i = 0; i < n; ++i) {
    v.theta_x_rad.push_back((r.y_F_px[i] - r.y_F_px[0]) / m);
    v.theta_y_rad.push_back((r.x_F_px[i] - r.x_F_px[0]) / m);
    v.X_F_m.push_back(k * (r.x_M_px[0] - r.x_F_px[0]) + (r.along_m[i] - r.along_m[0]) +
                      k * (r.x_F_px[i] - r.x_M_px[i]));
    v.Y_F_m.push_back(k * (r.y_M_px[0] - r.y_F_px[0]) + (r.across_m[i] - r.across_m[0]) +
                      k * (r.y_F_px[i] - r.y_M_px[i]));
  }
  return v;
}

ArtifactResult identify_artifact(const ArtifactReadings& calibration, const ArtifactReadings& horizontal,
                                 const ArtifactReadings& vertical, const ArtifactOptions& options) {
  const std::size_t n = calibration.target.size();
  for (const ArtifactReadings* r : {&horizontal, &vertical}) {
    if (r->target.size() != n)
      throw CsvError(r->source + ": " + std::to_string(r->target.size()) + " targets, but the calibration " +
                     calibration.source + " has " + std::to_string(n));
    if (r->axis != calibration.axis)
      throw CsvError(r->source + ": axis " + std::string(1, "xyz"[r->axis]) + ", but the calibration " +
                     calibration.source + " is along " + std::string(1, "xyz"[calibration.axis]));
  }
  ArtifactResult res;
  res.axis = calibration.axis;
  res.k_scan = options.k_scan;
  res.m_scan = options.m_scan;
  res.k_m_per_px = options.k_scan ? options.k_scan->coefficient : calibration.k_m_per_px;
  res.u_k_m_per_px = options.k_scan ? options.k_scan->u : calibration.u_k_m_per_px;
  res.m_px_per_rad = options.m_scan ? options.m_scan->coefficient : calibration.m_px_per_rad;
  res.u_m_px_per_rad = options.m_scan ? options.m_scan->u : calibration.u_m_px_per_rad;
  const double k = res.k_m_per_px;
  const double m = res.m_px_per_rad;
  if (!(k > 0))
    throw CsvError(calibration.source + ": missing metadata line '# k_um_per_px = <number>' (or give a k scan)");
  if (!(m > 0))
    throw CsvError(calibration.source + ": missing metadata line '# m_px_per_arcsec = <number>' (or give an m scan)");
  res.coupling_m_per_rad = k * m;
  Values base = compute(calibration, horizontal, vertical, k, m, options.angle_coupling);
  res.calibration = base.c;
  res.horizontal = base.h;
  res.vertical = base.v;

  // Uncertainties: every input is independent; each output is linear in the spots and positions
  // and bilinear in k and m, so a central difference of +-u gives its contribution exactly.
  std::vector<std::array<double, 7>> var(n, std::array<double, 7>{});
  auto add = [&](const Values& plus, const Values& minus) {
    for (std::size_t i = 0; i < n; ++i) {
      const auto a = outputs(plus.e[i]);
      const auto b = outputs(minus.e[i]);
      for (std::size_t q = 0; q < 7; ++q) var[i][q] += 0.25 * (a[q] - b[q]) * (a[q] - b[q]);
    }
  };
  ArtifactReadings files[3] = {calibration, horizontal, vertical};
  for (auto& f : files) {
    struct Field {
      std::vector<double>* values;
      double u;
    };
    const Field fields[] = {{&f.along_m, f.u_position_m}, {&f.across_m, f.u_position_m}, {&f.x_M_px, f.u_spot_px},
                            {&f.y_M_px, f.u_spot_px},     {&f.x_F_px, f.u_spot_px},      {&f.y_F_px, f.u_spot_px}};
    for (const auto& field : fields) {
      if (!(field.u > 0)) continue;
      for (std::size_t i = 0; i < n; ++i) {
        const double keep = (*field.values)[i];
        (*field.values)[i] = keep + field.u;
        const Values plus = compute(files[0], files[1], files[2], k, m, options.angle_coupling);
        (*field.values)[i] = keep - field.u;
        const Values minus = compute(files[0], files[1], files[2], k, m, options.angle_coupling);
        (*field.values)[i] = keep;
        add(plus, minus);
      }
    }
  }
  if (res.u_k_m_per_px > 0)
    add(compute(calibration, horizontal, vertical, k + res.u_k_m_per_px, m, options.angle_coupling),
        compute(calibration, horizontal, vertical, k - res.u_k_m_per_px, m, options.angle_coupling));
  if (res.u_m_px_per_rad > 0)
    add(compute(calibration, horizontal, vertical, k, m + res.u_m_px_per_rad, options.angle_coupling),
        compute(calibration, horizontal, vertical, k, m - res.u_m_px_per_rad, options.angle_coupling));

  res.targets = std::move(base.e);
  for (std::size_t i = 0; i < n; ++i) {
    auto& e = res.targets[i];
    e.u_dx_m = std::sqrt(var[i][0]);
    e.u_dy_m = std::sqrt(var[i][1]);
    e.u_dz_m = std::sqrt(var[i][2]);
    e.u_ex_rad = std::sqrt(var[i][3]);
    e.u_ey_rad = std::sqrt(var[i][4]);
    e.u_ez_rad = std::sqrt(var[i][5]);
    e.u_ex_vertical_rad = std::sqrt(var[i][6]);
  }
  return res;
}

}  // namespace guideway::models::artifact
