#pragma once
// The "profile" test session: one traverse of the profilometer-tcp device, from the point flagged
// profile start to the one flagged profile end, evaluated as the straightness of the profile (about
// its least-squares line and by the minimum zone) and summarised by its Daubechies wavelet
// multiresolution analysis (dsp/wavelet.hpp: db1, 5 levels by default, as Mu 2012): the form (the
// approximation's straightness), the rms of every detail band with its wavelength range, the dominant
// band, and the noise level from the finest details. The profile is written as a guideway/profile/1
// file and evaluated from that very text, so the derived file reproduces the result.

#include <string>

#include "formats/profile_files.hpp"
#include "results/params.hpp"
#include "sessions/session.hpp"

namespace guideway::sessions {

struct ProfileEvaluationOptions {
  std::string wavelet = "db1";
  std::string mode = "symmetric";
  int level = 5;
};

// The PARAMS body of a profile (pure; throws std::invalid_argument when the profile cannot be
// evaluated: fewer than 2^level points, unequal spacing, too many invalid points).
results::Params evaluate_profile(const formats::Profile& profile, const ProfileEvaluationOptions& options = {});

SessionKind profile_session_kind();

}  // namespace guideway::sessions
