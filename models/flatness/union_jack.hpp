#pragma once
// Surface-plate flatness by the Union Jack (Moody 1955) method (docs/formats.md, "Union Jack set"):
// eight lines of autocollimator readings (two diagonals, four perimeter lines, two centre lines), one
// file per line in a directory, plus Config.txt with the reflector foot spacing. The Moody
// evaluation fixes the datum plane by the diagonals (their centres at zero, each diagonal's ends at
// equal height), fits each perimeter line between its corner heights and each centre line between
// the perimeter midpoints, reports the centre-line closure errors, and finally shifts all heights so
// the lowest station is at zero (Moody's final worksheet column). Optionally a least-squares
// evaluation of all lines at once (one unknown angular offset per line). Pure functions; thread safe.

#include <array>
#include <cstddef>
#include <optional>
#include <string>
#include <vector>

#include "models/flatness/angles.hpp"

namespace guideway::models::flatness {

// The eight lines in the order of Moody's worksheets (and of reference_heights.dat).
enum class UnionJackLine : int { nw_se = 0, ne_sw, ne_nw, ne_se, se_sw, nw_sw, e_w, n_s };
// Plausible bounds (docs/formats.md, "Union Jack set"): a reflector's foot spacing, and the readings of one
// line (the least-squares evaluation's matrices grow with the square of the stations).
inline constexpr double union_jack_max_foot_spacing_m = 1.0;
inline constexpr std::size_t union_jack_max_readings = 2000;

inline constexpr std::array<const char*, 8> union_jack_names = {"NW_SE", "NE_SW", "NE_NW", "NE_SE",
                                                                "SE_SW", "NW_SW", "E_W",   "N_S"};

// The eight lines of readings and the foot spacing, as read from a directory (SI).
struct UnionJackSet {
  std::string dir;
  double foot_spacing_m = 0.0;
  bool inch_units = false;                            // Config.txt said I (inches): reports may add micro-inches
  std::array<std::vector<double>, 8> angle_rad;       // readings per line, in the order above
  std::array<std::vector<std::size_t>, 8> file_line;  // file line of each reading
};

// Reads DIR/Config.txt (`I <inches>` or `M <mm>`, first non-comment line; ignored when
// foot_spacing_override_m > 0) and DIR/<LINE>.txt (one reading in arc-seconds per line, `#`
// comments, blank lines skipped). Checks every reading (number, inside the instrument range) and the
// geometry (opposite perimeter lines and the parallel centre line have the same number of readings,
// both diagonals too, all even). Throws CsvError "file:line: message".
UnionJackSet read_union_jack(const std::string& dir, double foot_spacing_override_m = 0.0,
                             const Autocollimator& ac = {});

// One station: plate coordinates and height.
struct UnionJackStation {
  double x_steps = 0.0;  // plate coordinates in perimeter-station units (x east, y north; SW corner = 0, 0)
  double y_steps = 0.0;
  double height_m = 0.0;
};

// The stations of one line after Moody's evaluation.
struct UnionJackLineResult {
  std::string name;
  std::vector<UnionJackStation> stations;
  std::optional<double>
      closure_m;  // centre lines: height of the line's middle before it is shifted onto the plate centre
};

// The least-squares evaluation of all lines at once (heights relative to their least-squares plane).
struct UnionJackLsq {
  std::vector<UnionJackStation> stations;  // unique stations, heights relative to their least-squares plane
  std::vector<double> u_height_m;          // from the per-reading angle uncertainty (a priori)
  std::array<double, 8> offset_rad{};      // per-line angular offset (gauge: relative to the plane)
  double residual_rms_rad = 0.0;           // of the reading equations
  std::size_t readings = 0;
  std::size_t unknowns = 0;
  std::size_t redundancy = 0;        // readings - rank
  double flatness_m = 0.0;           // max - min over the unique stations
  double flatness_min_zone_m = 0.0;  // minimum zone of the unique stations
};

// Moody's evaluation of a set (and optionally the least-squares one).
struct UnionJackResult {
  double foot_spacing_m = 0.0;
  std::size_t long_steps = 0, short_steps = 0, diagonal_steps = 0;
  std::array<UnionJackLineResult, 8> lines;
  double flatness_m = 0.0;            // Moody: highest minus lowest station over the datum plane
  double flatness_lsq_plane_m = 0.0;  // Moody heights, peak to valley about their least-squares plane
  double flatness_min_zone_m = 0.0;   // Moody heights, minimum zone (ISO 12781 flatness)
  std::vector<std::string> warnings;  // e.g. station counts far from Pythagoras
  std::optional<UnionJackLsq> lsq;
};

// Evaluation settings.
struct UnionJackOptions {
  bool least_squares = false;
  Autocollimator instrument;
};

UnionJackResult evaluate_union_jack(const UnionJackSet& set, const UnionJackOptions& options = {});

}  // namespace guideway::models::flatness
