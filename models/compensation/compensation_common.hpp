#pragma once
// What the parts of the compensation (compensation_map, lai3_terms, compensation_files, compensation_text)
// share: a term looked up by name, the significance rule, an axis as the files print it. Internal to
// models/compensation; thread safe.

#include <cctype>
#include <string>
#include <vector>

namespace guideway::models::compensation::detail {

// A term is applied when it exceeds k standard uncertainties (k = 2, the usual expanded uncertainty):
// a correction smaller than that is mostly noise (an amplitude such as the cyclic error's is positive
// even when there is none, about 1.25 u on average).
inline constexpr double significance_k = 2.0;

// The item named `name` (an estimate, a term), nullptr for none.
template <class Named>
const Named* find(const std::vector<Named>& items, const std::string& name) {
  for (const auto& e : items)
    if (e.name == name) return &e;
  return nullptr;
}

// "x" -> "X", "xy" -> "XY".
inline std::string letters_upper(const std::string& s) {
  std::string o = s;
  for (auto& c : o) c = static_cast<char>(std::toupper(static_cast<unsigned char>(c)));
  return o;
}

}  // namespace guideway::models::compensation::detail
