// Streaming wavelet cascade: equality with the batch transforms (bit for bit), the latency contract, chunking
// independence, reset, and no allocation on push.
#include <gtest/gtest.h>

#include <atomic>
#include <cstdlib>
#include <new>
#include <random>

#include "dsp/streaming_wavelet.hpp"
#include "dsp/wavelet.hpp"

namespace {
std::atomic<std::size_t> g_allocations{0};
}  // namespace

// GCC cannot see that the replaced new and delete below pair malloc with free.
#pragma GCC diagnostic ignored "-Wmismatched-new-delete"

// Count every allocation of the process (the test reads the counter around push calls).
void* operator new(std::size_t n) {
  g_allocations.fetch_add(1, std::memory_order_relaxed);
  if (void* p = std::malloc(n == 0 ? 1 : n)) return p;
  throw std::bad_alloc();
}
void operator delete(void* p) noexcept { std::free(p); }
void operator delete(void* p, std::size_t) noexcept { std::free(p); }

namespace guideway::dsp {
namespace {

std::vector<double> random_signal(std::size_t n, unsigned seed) {
  std::mt19937_64 rng(seed);
  std::normal_distribution<double> g(0.0, 1.0);
  std::vector<double> x(n);
  double walk = 0.0;
  for (auto& v : x) {
    walk += 0.1 * g(rng);
    v = walk + g(rng);
  }
  return x;
}

struct Collect final : WaveletSink {
  explicit Collect(std::size_t bands) : coeffs(bands), comps(bands) {}
  void on_coefficients(std::size_t band, std::uint64_t first, std::span<const double> v) override {
    EXPECT_EQ(first, coeffs[band].size());
    coeffs[band].insert(coeffs[band].end(), v.begin(), v.end());
  }
  void on_components(std::uint64_t first, std::size_t count, std::span<const double* const> c) override {
    EXPECT_EQ(first, comps[0].size());
    for (std::size_t b = 0; b < c.size(); ++b) comps[b].insert(comps[b].end(), c[b], c[b] + count);
  }
  void on_denoised(std::uint64_t first, std::span<const double> v) override {
    EXPECT_EQ(first, denoised.size());
    denoised.insert(denoised.end(), v.begin(), v.end());
  }
  Coefficients coeffs;
  std::vector<std::vector<double>> comps;
  std::vector<double> denoised;
};

void push_in_chunks(StreamingWavelet& s, const std::vector<double>& x, Collect& sink, unsigned seed,
                    std::size_t max_chunk) {
  std::mt19937 rng(seed);
  std::uniform_int_distribution<std::size_t> len(0, max_chunk);
  std::size_t pos = 0;
  while (pos < x.size()) {
    const std::size_t n = std::min(len(rng), x.size() - pos);
    s.push(std::span<const double>(x).subspan(pos, n), sink);
    pos += n;
  }
}

class StreamingAgainstBatch : public ::testing::TestWithParam<std::tuple<const char*, int>> {};

TEST_P(StreamingAgainstBatch, CoefficientsAndComponentsEqualZeroModeBatchBitForBit) {
  const Wavelet w(std::get<0>(GetParam()));
  const int levels = std::get<1>(GetParam());
  for (std::size_t n : {1u, 2u, 7u, 64u, 1000u, 4097u}) {
    const auto x = random_signal(n, static_cast<unsigned>(n));
    StreamingOptions opt;
    opt.levels = levels;
    opt.components = true;
    opt.block = 256;
    StreamingWavelet s(w, opt);
    Collect sink(static_cast<std::size_t>(levels) + 1);
    push_in_chunks(s, x, sink, 7, 300);
    s.flush(sink);
    const Coefficients ref = wavedec(x, w, Mode::zero, levels);
    ASSERT_EQ(sink.coeffs.size(), ref.size());
    for (std::size_t b = 0; b < ref.size(); ++b) {
      ASSERT_EQ(sink.coeffs[b].size(), ref[b].size()) << "band " << b << " n=" << n;
      for (std::size_t i = 0; i < ref[b].size(); ++i) ASSERT_EQ(sink.coeffs[b][i], ref[b][i]) << b << ":" << i;
    }
    const auto comps = mra(x, w, Mode::zero, levels);
    for (std::size_t b = 0; b < comps.size(); ++b) {
      ASSERT_EQ(sink.comps[b].size(), n);
      for (std::size_t i = 0; i < n; ++i) ASSERT_EQ(sink.comps[b][i], comps[b][i]) << "component " << b << " t=" << i;
    }
  }
}

INSTANTIATE_TEST_SUITE_P(Wavelets, StreamingAgainstBatch,
                         ::testing::Values(std::make_tuple("db1", 5), std::make_tuple("db2", 1),
                                           std::make_tuple("db4", 5), std::make_tuple("db8", 3),
                                           std::make_tuple("sym5", 4), std::make_tuple("coif3", 2),
                                           std::make_tuple("db20", 2)));

// Interior coefficients equal the batch result in every other mode; only those reached by the edges differ.
TEST(Streaming, InteriorCoefficientsEqualEveryBatchMode) {
  const Wavelet w("db4");
  const int levels = 4;
  const std::size_t F = w.filter_length();
  const auto x = random_signal(3000, 3);
  StreamingOptions opt;
  opt.levels = levels;
  StreamingWavelet s(w, opt);
  Collect sink(levels + 1);
  s.push(x, sink);
  s.flush(sink);
  for (Mode mode : {Mode::symmetric, Mode::constant, Mode::reflect, Mode::periodic}) {
    const Coefficients ref = wavedec(x, w, mode, levels);
    // Leading coefficients touched by the left edge: level 1 has F/2 - 1, then each level's window reaches
    // ceil((bad + F - 2) / 2) coefficients.
    std::size_t bad = 0;
    for (int l = 1; l <= levels; ++l) {
      bad = (bad + F - 2 + 1) / 2;
      const std::size_t band = static_cast<std::size_t>(levels + 1 - l);
      // Trailing coefficients touched by the right edge: fewer than F at any level.
      for (std::size_t o = bad; o + F < ref[band].size(); ++o) {
        ASSERT_EQ(sink.coeffs[band][o], ref[band][o]) << mode_name(mode) << " level " << l << " o=" << o;
      }
    }
  }
}

TEST(Streaming, LatencyIsExactAndMinimal) {
  const Wavelet w("db4");
  const int levels = 3;
  StreamingOptions opt;
  opt.levels = levels;
  opt.components = true;
  opt.denoise = true;
  opt.denoise_options.threshold = 0.5;
  StreamingWavelet s(w, opt);
  const std::size_t L = s.latency();
  EXPECT_EQ(L, (w.filter_length() - 1) * ((1u << levels) - 1));
  const auto x = random_signal(2000, 11);
  Collect sink(levels + 1);
  for (std::size_t i = 0; i < x.size(); ++i) {
    s.push(std::span<const double>(&x[i], 1), sink);
    const std::size_t want = i + 1 > L ? i + 1 - L : 0;
    ASSERT_EQ(sink.comps[0].size(), want) << "after " << i + 1 << " samples";
    ASSERT_EQ(sink.denoised.size(), want);
  }
  // Minimal: some component sample t depends on input sample t + L (so no smaller fixed latency is possible).
  const auto base = mra(x, w, Mode::zero, levels);
  bool found = false;
  for (std::size_t t = 500; t < 500 + (1u << levels) && !found; ++t) {
    auto y = x;
    y[t + L] += 1.0;
    const auto pert = mra(y, w, Mode::zero, levels);
    for (std::size_t b = 0; b < base.size(); ++b) found = found || pert[b][t] != base[b][t];
  }
  EXPECT_TRUE(found);
}

TEST(Streaming, ChunkingDoesNotChangeAnyOutputAndResetRestarts) {
  const Wavelet w("sym6");
  StreamingOptions opt;
  opt.levels = 5;
  opt.components = true;
  opt.denoise = true;  // adaptive noise estimate: must not depend on chunking either
  opt.denoise_options.window = 128;
  const auto x = random_signal(5000, 5);
  StreamingWavelet s(w, opt);
  Collect one(6);
  s.push(x, one);
  s.flush(one);
  s.reset();
  Collect many(6);
  push_in_chunks(s, x, many, 99, 17);
  s.flush(many);
  EXPECT_EQ(one.coeffs, many.coeffs);
  EXPECT_EQ(one.comps, many.comps);
  EXPECT_EQ(one.denoised, many.denoised);
  ASSERT_EQ(one.denoised.size(), x.size());
  EXPECT_THROW(s.push(x, many), std::logic_error);
}

TEST(Streaming, FixedThresholdDenoisingEqualsBatchZeroMode) {
  const Wavelet w("db6");
  const auto x = random_signal(3001, 8);
  StreamingOptions opt;
  opt.levels = 4;
  opt.coefficients = false;
  opt.denoise = true;
  opt.denoise_options.threshold = 0.8;
  opt.denoise_options.rule = ThresholdRule::hard;
  StreamingWavelet s(w, opt);
  Collect sink(5);
  push_in_chunks(s, x, sink, 1, 64);
  s.flush(sink);
  DenoiseOptions bo;
  bo.threshold = 0.8;
  bo.rule = ThresholdRule::hard;
  const auto ref = denoise(x, w, Mode::zero, 4, bo);
  ASSERT_EQ(sink.denoised.size(), ref.signal.size());
  for (std::size_t i = 0; i < x.size(); ++i) ASSERT_EQ(sink.denoised[i], ref.signal[i]) << i;
  EXPECT_TRUE(sink.coeffs[0].empty());
}

TEST(Streaming, PushDoesNotAllocate) {
  const Wavelet w("db8");
  StreamingOptions opt;
  opt.levels = 5;
  opt.components = true;
  opt.denoise = true;
  StreamingWavelet s(w, opt);
  const auto x = random_signal(20000, 2);
  struct Null final : WaveletSink {
  } sink;
  s.push(std::span<const double>(x).first(100), sink);  // warm-up: nothing lazily allocated, but be fair
  const std::size_t before = g_allocations.load();
  std::size_t pos = 100;
  std::size_t chunk = 1;
  while (pos < x.size()) {
    const std::size_t n = std::min(chunk, x.size() - pos);
    s.push(std::span<const double>(x).subspan(pos, n), sink);
    pos += n;
    chunk = chunk * 3 % 2049 + 1;
  }
  s.flush(sink);
  s.reset();
  EXPECT_EQ(g_allocations.load(), before);
}

TEST(Streaming, RejectsBadConfiguration) {
  const Wavelet w("db4");
  StreamingOptions opt;
  opt.levels = 0;
  EXPECT_THROW(StreamingWavelet(w, opt), std::invalid_argument);
  opt.levels = 17;
  EXPECT_THROW(StreamingWavelet(w, opt), std::invalid_argument);
  opt.levels = 16;
  opt.components = true;  // 2^16 x 39 taps of history in ~150 FIFOs: refused, with the size in the message
  EXPECT_THROW(StreamingWavelet(Wavelet("db20"), opt), std::invalid_argument);
}

}  // namespace
}  // namespace guideway::dsp
