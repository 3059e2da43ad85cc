#pragma once
// The circular test's figures as ISO 230-4 and ASME B5.54 define them, each with the test conditions that
// make it comparable (docs/standards.md): per run, ISO 230-4's circular deviation G and radial deviation F
// (largest and smallest) and B5.54's circularity; per CCW/CW pair of one set-up, ISO 230-4's circular
// hysteresis H and bidirectional circular deviation G(b), B5.54's hysteresis and bidirectional circularity.
// A partial arc's figures are over its data arc. Pure functions; thread safe.

#include <optional>
#include <string>
#include <vector>

#include "formats/dbb_run.hpp"

namespace guideway::models::dbb {

// What a figure was measured under; the optional ones come from the run's metadata (`feed_in_deg`,
// `feed_out_deg` or `overshoot_deg` for both; `temperature_c`) and are "not recorded" without it.
struct TestConditions {
  double radius_mm = 0.0;
  double height_mm = 0.0;
  double feed_mm_per_min = 0.0;
  std::string direction;        // "ccw" | "cw"
  double data_arc_deg = 360.0;  // the arc the figures are over (360: the full circle)
  bool partial_arc = false;
  std::size_t samples = 0;
  double spacing_deg = 0.0;  // median step between samples
  std::size_t gaps = 0;
  std::optional<double> feed_in_deg, feed_out_deg, temperature_c;
};

struct RunFigures {
  std::string source;
  TestConditions conditions;
  double iso_circular_deviation_um = 0.0;    // G: range about the run's least-squares circle
  double iso_radial_deviation_max_um = 0.0;  // F: reading less the nominal radius, about that circle's centre
  double iso_radial_deviation_min_um = 0.0;
  double asme_circularity_um = 0.0;  // per direction, about the run's least-squares centre (= G)
};

struct PairFigures {
  std::size_t ccw = 0, cw = 0;                     // indices into the runs
  double common_arc_deg = 0.0;                     // of the angles both runs hold (the hysteresis is over those)
  double iso_circular_hysteresis_um = 0.0;         // H: largest difference of the two about their common circle
  double iso_bidirectional_deviation_um = 0.0;     // G(b): range of both about their common circle
  double asme_hysteresis_um = 0.0;                 // as H
  double asme_bidirectional_circularity_um = 0.0;  // as G(b)
};

struct StandardFigures {
  std::vector<RunFigures> runs;
  std::vector<PairFigures> pairs;  // each run in at most one pair, the first CCW/CW of one set-up
};

StandardFigures standard_figures(const std::vector<formats::DbbRun>& runs);

// ISO 230-4 circular hysteresis of two runs (um): their readings about their common least-squares circle,
// on a 0.5 deg grid, the largest difference over the angles both hold; NaN when their arcs do not overlap.
double circular_hysteresis_um(const formats::DbbRun& a, const formats::DbbRun& b);
// The degrees of that grid both runs hold.
double common_arc_deg(const formats::DbbRun& a, const formats::DbbRun& b);

}  // namespace guideway::models::dbb
