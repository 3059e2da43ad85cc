// The series helpers every model, report and session uses (dsp/series.hpp): invalid points, ends, and
// agreement with the definitions written out.
#include <gtest/gtest.h>

#include <cmath>

#include "dsp/series.hpp"

using guideway::dsp::fill_gaps_linear;
using guideway::dsp::peak_to_valley;
using guideway::dsp::rms;

namespace {
const double invalid = std::nan("");
}

TEST(Series, RmsIsTheRootOfTheMeanSquareAndZeroWhenEmpty) {
  EXPECT_DOUBLE_EQ(rms({3.0, -4.0}), std::sqrt(12.5));
  EXPECT_EQ(rms({}), 0.0);
  EXPECT_TRUE(std::isnan(rms({1.0, invalid}))) << "an invalid point is not silently dropped from an rms";
}

TEST(Series, PeakToValleySkipsInvalidPointsAndIsNanWithoutAValidOne) {
  EXPECT_DOUBLE_EQ(peak_to_valley({1.0, invalid, -2.5, 0.5}), 3.5);
  EXPECT_EQ(peak_to_valley({7.0}), 0.0);
  EXPECT_TRUE(std::isnan(peak_to_valley({})));
  EXPECT_TRUE(std::isnan(peak_to_valley({invalid, invalid})));
}

TEST(Series, GapsAreBridgedLinearlyAndHeldAtTheEnds) {
  const auto f = fill_gaps_linear({invalid, invalid, 1.0, invalid, invalid, 4.0, 5.0, invalid});
  const std::vector<double> want{1.0, 1.0, 1.0, 2.0, 3.0, 4.0, 5.0, 5.0};
  ASSERT_EQ(f.size(), want.size());
  for (std::size_t i = 0; i < want.size(); ++i) EXPECT_DOUBLE_EQ(f[i], want[i]) << i;
  const auto none = fill_gaps_linear({invalid, invalid});
  EXPECT_TRUE(std::isnan(none[0]) && std::isnan(none[1])) << "nothing to bridge from";
  EXPECT_TRUE(fill_gaps_linear({}).empty());
  const std::vector<double> whole{0.5, -1.0, 2.0};
  EXPECT_EQ(fill_gaps_linear(whole), whole);
}
