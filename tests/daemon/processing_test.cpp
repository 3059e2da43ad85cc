// The daemon's [[processing]] step: online wavelet denoising of one channel (daemon/channel_denoiser),
// checked against dsp::StreamingWavelet fed the same valid values, plus its configuration errors.
#include "daemon/channel_denoiser.hpp"

#include <gtest/gtest.h>

#include <cmath>
#include <limits>
#include <random>

#include "core/toml_access.hpp"
#include "daemon/config.hpp"
#include "daemon/processing_chain.hpp"

using namespace guideway;

namespace {

class Collect : public dsp::WaveletSink {
 public:
  void on_denoised(std::uint64_t first, std::span<const double> v) override {
    EXPECT_EQ(first, values.size());
    values.insert(values.end(), v.begin(), v.end());
  }
  std::vector<double> values;
};

dsp::StreamingOptions options() {
  dsp::StreamingOptions o;
  o.levels = 4;
  o.denoise = true;
  o.coefficients = false;
  o.denoise_options.window = 256;
  return o;
}

daemon::DenoiserSpec spec(std::size_t channel, const std::string& wavelet) {
  daemon::DenoiserSpec s;
  s.channel = channel;
  s.channel_name = "c" + std::to_string(channel);
  s.wavelet = wavelet;
  s.options = options();
  return s;
}

Sample make_sample(std::uint64_t seq, double v0, double v1) {
  Sample s;
  s.seq = seq;
  s.t_mono_ns = static_cast<std::int64_t>(seq) * 1000;
  s.value_count = 2;
  s.value[0] = v0;
  s.value[1] = v1;
  return s;
}

// Feeds `in` in random chunk sizes (at most max_batch) and returns everything that came out.
std::vector<Sample> run(daemon::ChannelDenoiser& d, const std::vector<Sample>& in, std::size_t max_batch,
                        std::mt19937& rng) {
  std::vector<Sample> out;
  out.reserve(in.size() + d.output_bound());
  std::uniform_int_distribution<std::size_t> chunk(0, max_batch);
  for (std::size_t i = 0; i < in.size();) {
    const std::size_t n = std::min(chunk(rng), in.size() - i);
    std::vector<Sample> part;
    part.reserve(d.output_bound());
    d.process(std::span<const Sample>(in).subspan(i, n), part);
    out.insert(out.end(), part.begin(), part.end());
    i += n;
  }
  return out;
}

}  // namespace

TEST(ChannelDenoiser, ValidStreamEqualsTheStreamingWaveletAfterItsLatencyInAnyChunking) {
  const dsp::Wavelet w("db4");
  std::mt19937 rng(7);
  std::normal_distribution<double> noise(0.0, 1e-6);
  std::vector<Sample> in;
  std::vector<double> values;
  for (std::uint64_t i = 0; i < 5000; ++i) {
    const double v = 1e-5 * std::sin(0.01 * static_cast<double>(i)) + noise(rng);
    in.push_back(make_sample(i, 42.0, v));
    values.push_back(v);
  }
  dsp::StreamingWavelet reference(w, options());
  Collect expected;
  reference.push(values, expected);

  daemon::ChannelDenoiser d(spec(1, "db4"), 64);
  EXPECT_EQ(d.latency_samples(), 7u * 15u);  // (F-1)(2^J-1) for db4, 4 levels
  const auto out = run(d, in, 64, rng);
  ASSERT_EQ(out.size(), in.size() - d.latency_samples());
  ASSERT_EQ(out.size(), expected.values.size());
  double changed = 0;
  for (std::size_t i = 0; i < out.size(); ++i) {
    EXPECT_EQ(out[i].seq, i);
    EXPECT_EQ(out[i].value[0], 42.0);  // other channels untouched
    EXPECT_EQ(out[i].value[1], expected.values[i]) << i;
    changed += std::abs(out[i].value[1] - values[i]);
  }
  EXPECT_GT(changed, 0.0);  // it did denoise
  EXPECT_EQ(d.passed_through(), 0u);
  EXPECT_EQ(d.restarts(), 0u);
}

TEST(ChannelDenoiser, UnusableSamplesPassThroughInTheirPlaceAndDoNotDisturbTheFilter) {
  const dsp::Wavelet w("db2");
  std::mt19937 rng(11);
  std::vector<Sample> in;
  std::vector<double> valid_values;
  for (std::uint64_t i = 0; i < 3000; ++i) {
    const double v = std::cos(0.003 * static_cast<double>(i));
    Sample s = make_sample(i, v, 0.0);
    if (i % 17 == 3) s.value[0] = std::numeric_limits<double>::quiet_NaN();
    if (i % 29 == 5) s.flags = sample_no_signal;
    if (i % 41 == 7) s.value_count = 0;  // channel missing
    if (std::isfinite(s.value[0]) && s.flags == 0 && s.value_count > 0) valid_values.push_back(v);
    in.push_back(s);
  }
  dsp::StreamingWavelet reference(w, options());
  Collect expected;
  reference.push(valid_values, expected);

  daemon::ChannelDenoiser d(spec(0, "db2"), 100);
  const auto out = run(d, in, 100, rng);
  std::size_t k = 0;
  for (std::size_t i = 0; i < out.size(); ++i) {
    ASSERT_EQ(out[i].seq, i);  // order kept, nothing lost
    const Sample& original = in[i];
    const bool valid = std::isfinite(original.value[0]) && original.flags == 0 && original.value_count > 0;
    if (valid) {
      EXPECT_EQ(out[i].value[0], expected.values.at(k++));
    } else {
      EXPECT_EQ(out[i].flags, original.flags);
      EXPECT_EQ(out[i].value_count, original.value_count);
      if (std::isnan(original.value[0])) {
        EXPECT_TRUE(std::isnan(out[i].value[0]));
      }
    }
  }
  EXPECT_EQ(k, expected.values.size());
  EXPECT_EQ(d.passed_through(), in.size() - valid_values.size());
}

TEST(ChannelDenoiser, ALongLossOfSignalRestartsTheFilterWithoutLosingASample) {
  daemon::ChannelDenoiser d(spec(0, "db4"), 512);
  std::vector<Sample> in;
  std::uint64_t seq = 0;
  for (int i = 0; i < 50; ++i) in.push_back(make_sample(seq++, 1.0, 0.0));  // fewer than the latency
  for (int i = 0; i < 20000; ++i) {
    Sample s = make_sample(seq++, 0.0, 0.0);
    s.flags = sample_out_of_range;
    in.push_back(s);
  }
  for (int i = 0; i < 1000; ++i) in.push_back(make_sample(seq++, 2.0, 0.0));
  std::mt19937 rng(3);
  const auto out = run(d, in, 512, rng);
  EXPECT_GE(d.restarts(), 1u);
  ASSERT_EQ(out.size(), in.size() - d.latency_samples());
  for (std::size_t i = 0; i < out.size(); ++i) ASSERT_EQ(out[i].seq, i);
  // The 50 early samples came out (flushed at the restart) with finite values.
  for (std::size_t i = 0; i < 50; ++i) EXPECT_TRUE(std::isfinite(out[i].value[0]));
}

TEST(ProcessingChain, ProcessThenFlushDeliversEverySampleOnceThroughTwoSteps) {
  // Two steps on two channels: every sample comes out once, in order, each channel equal to its own
  // streaming wavelet's output, the tails included.
  const auto s0 = spec(0, "db4");
  const auto s1 = spec(1, "db2");
  daemon::ProcessingChain chain({s0, s1}, 128);
  std::vector<Sample> in;
  std::vector<double> v0, v1;
  std::mt19937 rng(5);
  std::normal_distribution<double> noise(0.0, 0.1);
  for (std::uint64_t i = 0; i < 4000; ++i) {
    in.push_back(make_sample(i, std::sin(0.01 * static_cast<double>(i)) + noise(rng), noise(rng)));
    v0.push_back(in.back().value[0]);
    v1.push_back(in.back().value[1]);
  }
  Collect e0, e1;
  dsp::StreamingWavelet r0(dsp::Wavelet("db4"), options()), r1(dsp::Wavelet("db2"), options());
  r0.push(v0, e0);
  r0.flush(e0);
  r1.push(v1, e1);
  r1.flush(e1);
  std::vector<Sample> out;
  for (std::size_t i = 0; i < in.size(); i += 100) {
    const auto part = chain.process(std::span<const Sample>(in).subspan(i, std::min<std::size_t>(100, in.size() - i)));
    out.insert(out.end(), part.begin(), part.end());
  }
  const auto tail = chain.flush();
  out.insert(out.end(), tail.begin(), tail.end());
  ASSERT_EQ(out.size(), in.size());
  for (std::size_t i = 0; i < out.size(); ++i) {
    ASSERT_EQ(out[i].seq, i);
    EXPECT_EQ(out[i].value[0], e0.values[i]);
    EXPECT_EQ(out[i].value[1], e1.values[i]);
  }
  // The recorded description reads back to the same steps.
  const auto j = chain.to_json();
  const std::vector<drivers::ChannelInfo> channels = {{"c0", "m"}, {"c1", "m"}};
  const auto back = daemon::DenoiserSpec::from_json(j[1], channels);
  EXPECT_EQ(back.channel, 1u);
  EXPECT_EQ(back.wavelet, "db2");
  EXPECT_EQ(back.options.levels, 4);
  EXPECT_EQ(back.to_json(), j[1]);
  EXPECT_THROW((void)daemon::DenoiserSpec::from_json(j[1], {{"other", "m"}}), std::invalid_argument);
}

TEST(ProcessingConfig, ParsesDefaultsAndRejectsBadTablesWithFileAndLine) {
  const std::string device = "[[device]]\nname = \"dbb\"\ndriver = \"x\"\n";
  auto c = daemon::parse_config(device + "[[processing]]\ndevice = \"dbb\"\nchannel = \"bar_length\"\n", "p.toml");
  ASSERT_EQ(c.processing.size(), 1u);
  EXPECT_EQ(c.processing[0].wavelet, "db4");
  EXPECT_EQ(c.processing[0].levels, 4);
  EXPECT_EQ(c.processing[0].threshold, "soft");

  const auto error_of = [&](const std::string& text) {
    try {
      (void)daemon::parse_config(device + text, "p.toml");
    } catch (const ConfigError& e) {
      return std::string(e.what());
    }
    return std::string("no error");
  };
  EXPECT_NE(error_of("[[processing]]\ndevice = \"nope\"\nchannel = \"x\"\n").find("p.toml:"), std::string::npos);
  EXPECT_NE(error_of("[[processing]]\ndevice = \"dbb\"\nchannel = \"x\"\nwavelet = \"db99\"\n").find("wavelet"),
            std::string::npos);
  EXPECT_NE(error_of("[[processing]]\ndevice = \"dbb\"\nchannel = \"x\"\nlevels = 0\n").find("levels"),
            std::string::npos);
  EXPECT_NE(error_of("[[processing]]\ndevice = \"dbb\"\nchannel = \"x\"\nthreshold = \"medium\"\n").find("threshold"),
            std::string::npos);
  EXPECT_NE(error_of("[[processing]]\ndevice = \"dbb\"\nchannel = \"x\"\ncolour = 1\n").find("colour"),
            std::string::npos);
}
