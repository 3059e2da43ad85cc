#pragma once
// Squareness of the spindle to the cross carriage from a run-out revolution (Mu 2012, Eq. 21 and
// Fig. 10): an inductance micrometer on a thrust plate records the axial run-out over one (or more)
// revolutions; a least-squares sine fit extracts the once-per-revolution component
// z(phi) = c + A cos(phi - phase) (+ a twice-per-revolution term, so axial run-out does not leak in).
// The run-out r is its peak to peak, 2A (the total indicator reading of the tilt of the plate); with
// the plate-to-carriage parallelism p and the plate diameter L (probe at the rim):
// theta_0 = (r + p) / L, the squareness Delta beta_xz = theta_0, and its amplitude over the travel
// E_zq = theta_0 * travel (Eq. 15). Pure functions; thread safe. SI units inside.

#include <cstddef>
#include <optional>
#include <string>
#include <string_view>
#include <vector>

namespace guideway::models::flatness {

// One run-out recording with its set-up metadata (SI).
struct RunoutRevolution {
  std::string source;
  double plate_diameter_m = 0.0;
  double parallelism_m = 0.0;
  double u_parallelism_m = 0.0;    // optional `parallelism_u_um`
  std::optional<double> travel_m;  // optional `travel_mm`
  // Donaldson's reversal: how far the artifact (the plate) was turned about the spindle axis, in the
  // spindle's direction, since the record it is compared with (optional `artifact_turned_deg`).
  std::optional<double> artifact_turned_rad;
  // The angles count from the spindle's zero (an index, an encoder), the same in every record
  // (`angle_zero = spindle`, the default); false: from the record's first reading (`angle_zero =
  // first_reading`, what the runout session writes: the micrometer reads no spindle angle).
  bool angle_from_spindle_zero = true;
  std::vector<double> angle_rad;
  std::vector<double> runout_m;
  std::vector<std::size_t> line;
};

// Metadata plate_diameter_mm (> 0), parallelism_um, optional parallelism_u_um, travel_mm,
// artifact_turned_deg and angle_zero (spindle | first_reading); columns angle_deg,runout_um. At least 8 samples. Throws
// CsvError "file:line: message".
// A reading's plausible range (docs/formats.md, "Run-out revolution"): an inductance micrometer's range.
inline constexpr double runout_max_abs_um = 10000.0;
RunoutRevolution parse_runout_revolution(std::string_view text, const std::string& source);
RunoutRevolution read_runout_revolution(const std::string& path);

// The sine fit and Eq. 21; a value type.
struct RunoutResult {
  std::size_t samples = 0;
  double offset_m = 0.0;
  double amplitude_m = 0.0;  // A of the once-per-revolution term
  double u_amplitude_m = 0.0;
  double phase_rad = 0.0;  // angle of the maximum, in [0, 2 pi)
  double u_phase_rad = 0.0;
  double second_harmonic_m = 0.0;  // amplitude of the twice-per-revolution term
  double residual_rms_m = 0.0;
  double condition_number = 0.0;
  double runout_m = 0.0;  // r = 2 A
  double u_runout_m = 0.0;
  double parallelism_m = 0.0;
  double plate_diameter_m = 0.0;
  double deflection_rad = 0.0;  // theta_0 = (r + p) / L = squareness Delta beta_xz
  double u_deflection_rad = 0.0;
  std::optional<double> travel_m;
  std::optional<double> squareness_amplitude_m;  // theta_0 * travel
  std::optional<double> u_squareness_amplitude_m;
};

// Throws CsvError when the angles do not determine the sine (too few samples or too narrow an arc).
RunoutResult identify_runout(const RunoutRevolution& rev);

}  // namespace guideway::models::flatness
