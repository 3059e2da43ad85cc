// `guideway wavelet wavedec|mra|denoise` and `guideway correlate`: offline wavelet analysis of a recording or
// profile column (docs/cli.md). Results are JSON on stdout (PyWavelets' band order); errors name file and line.
#include <cmath>
#include <cstdio>
#include <fstream>
#include <iostream>
#include <memory>
#include <optional>
#include <sstream>
#include <stdexcept>
#include <string>
#include <vector>

#include <nlohmann/json.hpp>

#include "cli/commands.hpp"
#include "core/csv_table.hpp"
#include "dsp/correlation.hpp"
#include "dsp/denoise.hpp"
#include "dsp/wavelet.hpp"

namespace guideway::cli {

namespace {

struct Signal {
  std::string file;
  std::string column;
  std::vector<double> values;
};

Signal load_signal(const std::string& file, const std::optional<std::string>& column) {
  const CsvTable t = read_csv_table(file);
  const std::size_t col = t.select_column(column);
  Signal s{t.source, t.columns[col], t.numbers(col)};
  if (s.values.empty()) throw std::runtime_error(t.source + ": column '" + s.column + "' has no data rows");
  return s;
}

// Shortest text that reads back to the same double.
std::string number_text(double v) {
  char buf[32];
  for (int prec = 15; prec <= 17; ++prec) {
    std::snprintf(buf, sizeof buf, "%.*g", prec, v);
    if (std::strtod(buf, nullptr) == v) break;
  }
  return buf;
}

// The options every wavelet command takes.
struct WaveletArgs {
  std::string wavelet = "db4";
  std::string mode = "symmetric";
  int level = -1;
  std::optional<std::string> column;
  std::string file;
  void add(CLI::App& cmd) {
    cmd.add_option("--wavelet", wavelet, "db1..db20 (haar), sym2..sym20, coif1..coif5")->capture_default_str();
    cmd.add_option("--mode", mode, "signal extension: zero, constant, symmetric, periodic, reflect, periodization")
        ->capture_default_str();
    cmd.add_option("--level", level, "decomposition levels (default: pywt.dwt_max_level for the signal length)");
    cmd.add_option("--column", column, "column to analyse (required when the file has several)");
    cmd.add_option("FILE", file, "CSV with a header row (and # metadata), or one number per line; - = stdin")
        ->required();
  }
};

struct Prepared {
  Signal signal;
  dsp::Wavelet wavelet;
  dsp::Mode mode;
  int level;
};

Prepared prepare(const WaveletArgs& a) {
  dsp::Wavelet w(a.wavelet);
  const dsp::Mode mode = dsp::parse_mode(a.mode);
  Signal s = load_signal(a.file, a.column);
  if (a.level < -1) throw std::runtime_error("--level must be >= 0");
  const int level = a.level < 0 ? dsp::dwt_max_level(s.values.size(), w.filter_length()) : a.level;
  return {std::move(s), w, mode, level};
}

nlohmann::ordered_json header(const Prepared& p) {
  nlohmann::ordered_json j;
  j["file"] = p.signal.file;
  j["column"] = p.signal.column;
  j["samples"] = p.signal.values.size();
  j["wavelet"] = std::string(p.wavelet.name());
  j["mode"] = std::string(dsp::mode_name(p.mode));
  j["level"] = p.level;
  return j;
}

std::vector<std::string> band_names(int level) {
  std::vector<std::string> names{"a" + std::to_string(level)};
  for (int l = level; l >= 1; --l) names.push_back("d" + std::to_string(l));
  return names;
}

void write_file(const std::string& path, const std::string& text) {
  std::ofstream out(path, std::ios::binary | std::ios::trunc);
  out << text;
  out.close();
  if (!out) throw std::runtime_error(path + ": cannot write");
}

// The `# key = value` lines that say where a written signal comes from.
std::string provenance(const Prepared& p) {
  std::ostringstream o;
  o << "# source = " << p.signal.file << "\n# column = " << p.signal.column << "\n# wavelet = " << p.wavelet.name()
    << "\n# mode = " << dsp::mode_name(p.mode) << "\n# level = " << p.level << "\n";
  return o.str();
}

void run_wavedec(const WaveletArgs& a, CliContext& /*ctx*/) {
  const Prepared p = prepare(a);
  nlohmann::ordered_json j = header(p);
  j["bands"] = band_names(p.level);
  j["coeffs"] = dsp::wavedec(p.signal.values, p.wavelet, p.mode, p.level);
  std::cout << j.dump() << "\n";
}

struct MraArgs : WaveletArgs {
  std::string out;
  void add(CLI::App& cmd) {
    WaveletArgs::add(cmd);
    cmd.add_option("--out", out, "also write the components as CSV columns aJ,dJ,...,d1 to this file");
  }
};

void run_mra(const MraArgs& a, CliContext& /*ctx*/) {
  const Prepared p = prepare(a);
  const auto comps = dsp::mra(p.signal.values, p.wavelet, p.mode, p.level);
  const auto names = band_names(p.level);
  nlohmann::ordered_json j = header(p);
  j["bands"] = names;
  j["components"] = comps;
  if (!a.out.empty()) {
    std::ostringstream csv;
    csv << provenance(p);
    for (std::size_t b = 0; b < names.size(); ++b) csv << (b ? "," : "") << names[b];
    csv << "\n";
    for (std::size_t i = 0; i < p.signal.values.size(); ++i) {
      for (std::size_t b = 0; b < comps.size(); ++b) csv << (b ? "," : "") << number_text(comps[b][i]);
      csv << "\n";
    }
    write_file(a.out, csv.str());
  }
  std::cout << j.dump() << "\n";
}

struct DenoiseArgs : WaveletArgs {
  std::string rule = "soft";
  bool level_dependent = false;
  std::optional<double> sigma;
  std::string out;
  void add(CLI::App& cmd) {
    WaveletArgs::add(cmd);
    cmd.add_option("--rule", rule, "soft or hard thresholding")->capture_default_str();
    cmd.add_flag("--level-dependent", level_dependent, "estimate the noise level per level (default: finest)");
    cmd.add_option("--sigma", sigma, "known noise standard deviation (default: median(|cD_1|)/0.6745)");
    cmd.add_option("--out", out, "write a CSV (metadata + one column) here instead of numbers on stdout");
  }
};

void run_denoise(const DenoiseArgs& a, CliContext& /*ctx*/) {
  const Prepared p = prepare(a);
  dsp::DenoiseOptions o;
  o.rule = dsp::parse_threshold_rule(a.rule);
  o.level_dependent = a.level_dependent;
  o.sigma = a.sigma;
  const auto r = dsp::denoise(p.signal.values, p.wavelet, p.mode, p.level, o);
  std::ostringstream text;
  if (!a.out.empty()) {
    text << provenance(p) << "# rule = " << a.rule << "\n# level_dependent = " << (a.level_dependent ? "true" : "false")
         << "\n# sigma = " << number_text(r.sigma) << "\n# thresholds = " << nlohmann::ordered_json(r.thresholds).dump()
         << "\n"
         << p.signal.column << "_denoised\n";
  }
  for (double v : r.signal) text << number_text(v) << "\n";
  if (a.out.empty()) {
    std::cout << text.str();
    return;
  }
  write_file(a.out, text.str());
  nlohmann::ordered_json j = header(p);
  j["out"] = a.out;
  j["sigma"] = r.sigma;
  j["thresholds"] = r.thresholds;
  std::cout << j.dump() << "\n";
}

struct CorrelateArgs {
  std::string file_a;
  std::string file_b;
  std::optional<std::string> column;
  std::optional<std::string> column_b;
  std::size_t max_lag = 1000;
  std::string wavelet = "db1";
  std::string mode = "symmetric";
  int lowpass_level = 0;
  void add(CLI::App& cmd) {
    cmd.add_option("FILE_A", file_a, "first signal (CSV or one number per line)")->required();
    cmd.add_option("FILE_B", file_b, "second signal, same length")->required();
    cmd.add_option("--column", column, "column of FILE_A (and of FILE_B unless --column-b)");
    cmd.add_option("--column-b", column_b, "column of FILE_B");
    cmd.add_option("--max-lag", max_lag, "largest lag of the cross-correlation, in samples")->capture_default_str();
    cmd.add_option("--lowpass-level", lowpass_level,
                   "also correlate the approximation component A_j of FILE_A at this level (Mu Eq. 20)");
    cmd.add_option("--wavelet", wavelet, "wavelet for --lowpass-level")->capture_default_str();
    cmd.add_option("--mode", mode, "signal extension for --lowpass-level")->capture_default_str();
  }
};

// Pearson, the cross-correlation peak and, with --lowpass-level, Pearson of A_j of a with b into `j`.
void correlations(const Signal& a, const Signal& b, const CorrelateArgs& c, nlohmann::ordered_json& j) {
  j["pearson"] = dsp::pearson(a.values, b.values);
  const auto x = dsp::cross_correlation(a.values, b.values, c.max_lag);
  j["max_lag"] = x.max_lag;
  j["peak"] = {{"lag", x.peak_lag}, {"value", x.peak_value}};
  if (c.lowpass_level > 0) {
    const dsp::Wavelet w(c.wavelet);
    const auto r = dsp::wavelet_correlation(a.values, {b.values}, w, dsp::parse_mode(c.mode), c.lowpass_level);
    j["lowpass"] = {
        {"wavelet", std::string(w.name())}, {"mode", c.mode}, {"level", c.lowpass_level}, {"pearson", r.gamma_x1_y[0]}};
  }
}

void run_correlate(const CorrelateArgs& c, CliContext& /*ctx*/) {
  const Signal a = load_signal(c.file_a, c.column);
  const Signal b = load_signal(c.file_b, c.column_b ? c.column_b : c.column);
  if (a.values.size() != b.values.size()) {
    throw std::runtime_error("correlate: " + a.file + " has " + std::to_string(a.values.size()) + " samples, " +
                             b.file + " has " + std::to_string(b.values.size()) + ": the signals must be equally long");
  }
  nlohmann::ordered_json j;
  j["file_a"] = a.file;
  j["column_a"] = a.column;
  j["file_b"] = b.file;
  j["column_b"] = b.column;
  j["samples"] = a.values.size();
  try {
    correlations(a, b, c, j);
  } catch (const dsp::CorrelationError& e) {
    throw std::runtime_error("correlate " + a.file + " (" + a.column + ") with " + b.file + " (" + b.column +
                             "): " + e.what());
  }
  std::cout << j.dump() << "\n";
}

void add_wavelet_commands(CLI::App& app, CliContext& ctx) {
  auto* wavelet = app.add_subcommand("wavelet",
                                     "Wavelet decomposition, multiresolution analysis and denoising of a "
                                     "signal column (PyWavelets-compatible)");
  wavelet->require_subcommand(1);
  add_commands(*wavelet, ctx,
               {command("wavedec", "Print the coefficients [cA_J, cD_J, ..., cD_1] as JSON", &run_wavedec),
                command("mra", "Print the signal-domain components [A_J, D_J, ..., D_1] as JSON", &run_mra),
                command("denoise", "Universal-threshold denoising; writes the denoised signal", &run_denoise)});
  add_commands(app, ctx,
               {command("correlate",
                        "Pearson coefficient and normalised cross-correlation peak of two signals (Mu et al. Eq. 6; "
                        "Eq. 20 with --lowpass-level)",
                        &run_correlate)});
}

const CommandGroup wavelet_commands(&add_wavelet_commands);

}  // namespace

}  // namespace guideway::cli
