// Helper for tests/dsp/dsp_reference_test.py: runs the dsp library on the cases of a JSON file and writes the
// results as JSON, so the Python test can compare them with PyWavelets/numpy.
//   dsp_reference_tool CASES.json RESULTS.json
// A case: {"op": "wavedec"|"waverec"|"mra"|"dwt"|"idwt"|"denoise"|"pearson"|"xcorr"|"stream",
//          "wavelet", "mode", "level", "x": [...], "coeffs": [[...], ...], ...}. Errors are reported per case.
#include <cmath>
#include <fstream>
#include <iostream>
#include <nlohmann/json.hpp>

#include "dsp/correlation.hpp"
#include "dsp/denoise.hpp"
#include "dsp/streaming_wavelet.hpp"
#include "dsp/wavelet.hpp"

using nlohmann::json;
using namespace guideway;

namespace {

struct CollectCoefficients final : dsp::WaveletSink {
  explicit CollectCoefficients(std::size_t bands) : out(bands) {}
  void on_coefficients(std::size_t band, std::uint64_t first_index, std::span<const double> values) override {
    if (first_index != out[band].size()) throw std::logic_error("coefficients out of order");
    out[band].insert(out[band].end(), values.begin(), values.end());
  }
  dsp::Coefficients out;
};

json run_case(const json& c) {
  const std::string op = c.at("op");
  json r;
  if (op == "pearson") {
    auto x = c.at("x").get<std::vector<double>>();
    if (c.contains("nan_at")) x.at(c["nan_at"].get<std::size_t>()) = std::nan("");  // JSON has no NaN
    r["value"] = dsp::pearson(x, c.at("y").get<std::vector<double>>());
    return r;
  }
  if (op == "xcorr") {
    const auto res = dsp::cross_correlation(c.at("x").get<std::vector<double>>(), c.at("y").get<std::vector<double>>(),
                                            c.at("max_lag").get<std::size_t>());
    r["values"] = res.values;
    r["peak_lag"] = res.peak_lag;
    r["peak_value"] = res.peak_value;
    return r;
  }
  const dsp::Wavelet w(c.at("wavelet").get<std::string>());
  const dsp::Mode mode = dsp::parse_mode(c.value("mode", std::string("zero")));
  const int level = c.value("level", -1);
  if (op == "wavedec") {
    r["coeffs"] = dsp::wavedec(c.at("x").get<std::vector<double>>(), w, mode, level);
  } else if (op == "waverec") {
    r["x"] = dsp::waverec(c.at("coeffs").get<dsp::Coefficients>(), w, mode);
  } else if (op == "roundtrip") {
    // waverec(wavedec(x)) trimmed to N, and the sum of the MRA components.
    const auto x = c.at("x").get<std::vector<double>>();
    auto rec = dsp::waverec(dsp::wavedec(x, w, mode, level), w, mode);
    rec.resize(x.size());
    std::vector<double> sum(x.size(), 0.0);
    for (const auto& comp : dsp::mra(x, w, mode, level)) {
      for (std::size_t i = 0; i < x.size(); ++i) sum[i] += comp[i];
    }
    r["rec"] = rec;
    r["mra_sum"] = sum;
  } else if (op == "mra") {
    r["components"] = dsp::mra(c.at("x").get<std::vector<double>>(), w, mode, level);
  } else if (op == "dwt") {
    const auto b = dsp::dwt(c.at("x").get<std::vector<double>>(), w, mode);
    r["coeffs"] = json::array({b.approx, b.detail});
  } else if (op == "idwt") {
    r["x"] = dsp::idwt(c.at("a").get<std::vector<double>>(), c.at("d").get<std::vector<double>>(), w, mode);
  } else if (op == "denoise") {
    dsp::DenoiseOptions opt;
    opt.rule = c.at("rule") == "hard" ? dsp::ThresholdRule::hard : dsp::ThresholdRule::soft;
    opt.level_dependent = c.at("level_dependent").get<bool>();
    const auto res = dsp::denoise(c.at("x").get<std::vector<double>>(), w, mode, level, opt);
    r["x"] = res.signal;
    r["thresholds"] = res.thresholds;
  } else if (op == "stream") {
    // Streaming decomposition (zero-mode cascade) in the given chunk sizes, then flush.
    const auto x = c.at("x").get<std::vector<double>>();
    dsp::StreamingOptions opt;
    opt.levels = level;
    dsp::StreamingWavelet s(w, opt);
    CollectCoefficients sink(static_cast<std::size_t>(level) + 1);
    const auto chunks = c.at("chunks").get<std::vector<std::size_t>>();
    std::size_t pos = 0;
    for (std::size_t i = 0; pos < x.size(); ++i) {
      const std::size_t n = std::min(chunks[i % chunks.size()], x.size() - pos);
      s.push(std::span<const double>(x).subspan(pos, n), sink);
      pos += n;
    }
    s.flush(sink);
    r["coeffs"] = sink.out;
  } else {
    throw std::invalid_argument("unknown op " + op);
  }
  return r;
}

}  // namespace

int main(int argc, char** argv) {
  if (argc != 3) {
    std::cerr << "usage: dsp_reference_tool CASES.json RESULTS.json\n";
    return 2;
  }
  std::ifstream in(argv[1]);
  const json cases = json::parse(in);
  json results = json::array();
  for (const auto& c : cases) {
    try {
      results.push_back(run_case(c));
    } catch (const std::exception& e) {
      results.push_back(json{{"error", e.what()}});
    }
  }
  std::ofstream out(argv[2]);
  out << results.dump();
  return out ? 0 : 1;
}
