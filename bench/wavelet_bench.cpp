// Wavelet throughput (bench/README.md, "Wavelets"): batch wavedec, waverec and the full MRA (decomposition plus
// every band's signal-domain component) of 1e6 and 1e7 float64 samples at 5 levels, and the streaming
// decomposition pushed in small chunks. Single thread. Rates are input samples per second (items_per_second).
// bench/wavelet_vs_pywt.py runs this next to PyWavelets and prints the ratios.
#include <benchmark/benchmark.h>

#include <random>
#include <vector>

#include "dsp/streaming_wavelet.hpp"
#include "dsp/wavelet.hpp"

namespace {

using guideway::dsp::Mode;
using guideway::dsp::Wavelet;
using guideway::dsp::WaveletPlan;

constexpr int kLevels = 5;
const char* const kWavelets[] = {"db1", "db4", "db8"};

std::vector<double> signal(std::size_t n) {
  std::mt19937_64 rng(1);
  std::normal_distribution<double> g;
  std::vector<double> x(n);
  for (auto& v : x) v = g(rng);
  return x;
}

const std::vector<double>& input(std::size_t n) {
  static std::vector<double> x1 = signal(1'000'000);
  static std::vector<double> x2 = signal(10'000'000);
  return n == x1.size() ? x1 : x2;
}

void args(benchmark::internal::Benchmark* b) {
  for (int w = 0; w < 3; ++w) {
    for (long n : {1'000'000L, 10'000'000L}) b->Args({w, n});
  }
  b->Unit(benchmark::kMillisecond);
}

void BM_wavedec(benchmark::State& state) {
  const Wavelet w(kWavelets[state.range(0)]);
  const auto& x = input(static_cast<std::size_t>(state.range(1)));
  WaveletPlan plan(w, Mode::periodization, x.size(), kLevels);
  std::vector<double> packed(plan.coeff_count());
  for (auto _ : state) {
    plan.decompose(x, packed);
    benchmark::DoNotOptimize(packed.data());
    benchmark::ClobberMemory();
  }
  state.SetItemsProcessed(static_cast<std::int64_t>(state.iterations()) * state.range(1));
  state.SetLabel(std::string(w.name()));
}
BENCHMARK(BM_wavedec)->Apply(args);

void BM_waverec(benchmark::State& state) {
  const Wavelet w(kWavelets[state.range(0)]);
  const auto& x = input(static_cast<std::size_t>(state.range(1)));
  WaveletPlan plan(w, Mode::periodization, x.size(), kLevels);
  std::vector<double> packed(plan.coeff_count());
  std::vector<double> out(plan.reconstruction_length());
  plan.decompose(x, packed);
  for (auto _ : state) {
    plan.reconstruct(packed, out);
    benchmark::DoNotOptimize(out.data());
    benchmark::ClobberMemory();
  }
  state.SetItemsProcessed(static_cast<std::int64_t>(state.iterations()) * state.range(1));
  state.SetLabel(std::string(w.name()));
}
BENCHMARK(BM_waverec)->Apply(args);

// Full MRA from the signal: decomposition + the 6 components (A5, D5..D1), each the signal's length.
void BM_mra(benchmark::State& state) {
  const Wavelet w(kWavelets[state.range(0)]);
  const auto& x = input(static_cast<std::size_t>(state.range(1)));
  WaveletPlan plan(w, Mode::periodization, x.size(), kLevels);
  std::vector<double> packed(plan.coeff_count());
  std::vector<double> comps(plan.band_count() * x.size());
  for (auto _ : state) {
    plan.decompose(x, packed);
    plan.components(packed, comps);
    benchmark::DoNotOptimize(comps.data());
    benchmark::ClobberMemory();
  }
  state.SetItemsProcessed(static_cast<std::int64_t>(state.iterations()) * state.range(1));
  state.SetLabel(std::string(w.name()));
}
BENCHMARK(BM_mra)->Apply(args);

struct CountingSink final : guideway::dsp::WaveletSink {
  void on_coefficients(std::size_t, std::uint64_t, std::span<const double> v) override { n += v.size(); }
  void on_components(std::uint64_t, std::size_t count, std::span<const double* const>) override { n += count; }
  std::size_t n = 0;
};

// Streaming decomposition (coefficients delivered to a sink; with range(2) = 1 also the MRA components),
// 1e6 samples pushed in chunks of range(1) samples.
void BM_streaming(benchmark::State& state) {
  const Wavelet w(kWavelets[state.range(0)]);
  const auto chunk = static_cast<std::size_t>(state.range(1));
  const auto& x = input(1'000'000);
  guideway::dsp::StreamingOptions opt;
  opt.levels = kLevels;
  opt.components = state.range(2) != 0;
  guideway::dsp::StreamingWavelet s(w, opt);
  CountingSink sink;
  for (auto _ : state) {
    s.reset();
    for (std::size_t pos = 0; pos < x.size(); pos += chunk) {
      s.push(std::span<const double>(x).subspan(pos, std::min(chunk, x.size() - pos)), sink);
    }
    benchmark::DoNotOptimize(sink.n);
  }
  state.SetItemsProcessed(static_cast<std::int64_t>(state.iterations()) * static_cast<std::int64_t>(x.size()));
  state.SetLabel(opt.components ? "mra" : "coefficients");
}
BENCHMARK(BM_streaming)->ArgsProduct({{0, 1, 2}, {16, 256}, {0}})->Args({1, 256, 1})->Unit(benchmark::kMillisecond);

}  // namespace

BENCHMARK_MAIN();
