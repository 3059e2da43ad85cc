#pragma once
// Reproducible pseudo-random numbers for the simulators: the same seed gives the same sequence on
// every platform (mt19937_64 plus our own Box-Muller, since std::normal_distribution is not
// specified bit-for-bit). Not thread safe; one per query.

#include <cmath>
#include <cstdint>
#include <numbers>
#include <random>

namespace guideway::simulators::machine {

class Rng {
 public:
  explicit Rng(std::uint64_t seed) : engine_(seed) {}
  // Uniform in (0, 1).
  double uniform() { return (static_cast<double>(engine_() >> 11) + 0.5) * (1.0 / 9007199254740992.0); }
  // Standard normal.
  double normal() {
    if (has_spare_) {
      has_spare_ = false;
      return spare_;
    }
    const double u1 = uniform(), u2 = uniform();
    const double rad = std::sqrt(-2.0 * std::log(u1));
    spare_ = rad * std::sin(2.0 * std::numbers::pi * u2);
    has_spare_ = true;
    return rad * std::cos(2.0 * std::numbers::pi * u2);
  }

 private:
  std::mt19937_64 engine_;
  double spare_ = 0.0;
  bool has_spare_ = false;
};

}  // namespace guideway::simulators::machine
