// vibration: a structural or drive vibration at a fixed frequency, found as the strongest lines of the
// residual's periodogram in time along each direction.
#include <algorithm>
#include <array>
#include <cmath>
#include <complex>
#include <limits>
#include <memory>
#include <mutex>
#include <numbers>

#include <unsupported/Eigen/FFT>

#include "models/dbb/fast_sincos.hpp"
#include "models/explain/effects/dbb_terms.hpp"
#include "models/explain/effects/effect.hpp"
#include "results/parameters.hpp"

namespace guideway::models::explain::effects {

namespace {

// Sums of w^2, w^2 t and w^2 t^2 over a run's samples (w a projection on the bar, t in s).
struct Moments {
  double w2 = 0, w2t = 0, w2t2 = 0;
};

// A sample's projection on the bar of a vibration along direction `which` (0 the bar, 1 axis a, 2 axis b).
double weight(const Geo& p, int which) { return which == 0 ? 1.0 : p.lambda * (which == 1 ? p.c : p.s); }

// Amplitude, phase(s) and frequency of one line from its fitted sine/cosine pairs (one pair per phase
// group). Per group: amplitude and phase with the frequency held; then u(f) from the Fisher information of
// all groups, sigma^2 read back from the sine coefficient's variance (about 2 sigma^2 / sum w^2), and each
// phase's u widened by 2 pi t_centroid u(f).
std::vector<ParamValue> line_report(const std::string& along, std::size_t phases, double f,
                                    const std::vector<Moments>& mom, const Eigen::VectorXd& x,
                                    const Eigen::MatrixXd& cov) {
  const std::string amp = results::name_along(results::vibration, along);
  const std::string phase = results::name_along(results::vibration_phase, along);
  std::vector<std::vector<ParamValue>> ap(phases);
  std::vector<Moments> group(phases);  // a phase group's moments: its runs' summed
  for (std::size_t run = 0; run < mom.size(); ++run) {
    Moments& m = group[phases > 1 ? run : 0];
    m.w2 += mom[run].w2;
    m.w2t += mom[run].w2t;
    m.w2t2 += mom[run].w2t2;
  }
  double info = 0.0, sigma2 = 0.0;
  for (std::size_t k = 0; k < phases; ++k) {
    const auto j = static_cast<Eigen::Index>(2 * k);
    ap[k] = amp_phase(amp, phases > 1 ? results::run_suffixed(phase, static_cast<int>(k + 1)) : phase, x.segment(j, 2),
                      cov.block(j, j, 2, 2));
    sigma2 += 0.25 * (cov(j, j) + cov(j + 1, j + 1)) * group[k].w2 / static_cast<double>(phases);
  }
  for (std::size_t run = 0; run < mom.size(); ++run) {
    const Moments& m = mom[run];
    const double spread = m.w2 > 0 ? m.w2t2 - m.w2t * m.w2t / m.w2 : 0.0;
    const double a = ap[phases > 1 ? run : 0][0].value;
    info += 2 * pi * pi * a * a * spread;
  }
  const double u_f = sigma2 > 0 && info > 0 ? std::sqrt(sigma2 / info) : std::numeric_limits<double>::quiet_NaN();
  std::vector<ParamValue> values;
  if (phases == 1) {
    values.push_back(ap[0][0]);
  } else {
    // One amplitude: the runs' weighted by their inverse variances.
    double sw = 0, swa = 0;
    for (const auto& a : ap)
      if (a[0].u > 0) {
        sw += 1 / (a[0].u * a[0].u);
        swa += a[0].value / (a[0].u * a[0].u);
      }
    values.push_back({amp, sw > 0 ? swa / sw : ap[0][0].value,
                      sw > 0 ? 1 / std::sqrt(sw) : std::numeric_limits<double>::quiet_NaN()});
  }
  for (std::size_t k = 0; k < phases; ++k) {
    ParamValue ph = ap[k][1];
    const double centroid = group[k].w2 > 0 ? group[k].w2t / group[k].w2 : 0.0;
    const double from_f = 360.0 * centroid * u_f;  // deg
    ph.u = std::sqrt(ph.u * ph.u + from_f * from_f);
    values.push_back(ph);
  }
  values.push_back({results::name(results::vibration_frequency), f, u_f});
  return values;
}

// The search: the periodogram by FFT of each run's weighted residual binned on a uniform grid of step dt
// (live time stamps jitter; the bins only choose the candidate lines, fitted on the exact times),
// zero-padded to m >= 4 t_span / dt points (a power of two, at most 2^20), so the grid q / (m dt)
// oversamples the Fourier resolution 1/t_span about 4x; each line is then placed between grid points on
// the exact periodogram.
class LineSearch {
 public:
  LineSearch(const DbbTerms& t, double dt, double t_span) : geo_(t.geo), dt_(dt), plane_(t.plane) {
    while (static_cast<double>(fft_size_) < 4.0 * t_span / dt + 1 && fft_size_ < (std::size_t{1} << 20)) fft_size_ *= 2;
    df_ = 1.0 / (static_cast<double>(fft_size_) * dt);
    const double f_lo = 4.0 / t_span, f_hi = 0.4 / dt;
    q_lo_ = static_cast<std::size_t>(std::ceil(f_lo / df_));
    const auto q_hi = std::min(static_cast<std::size_t>(std::floor(f_hi / df_)), fft_size_ / 2 - 1);
    grid_ = q_hi >= q_lo_ ? q_hi - q_lo_ + 1 : 0;
    // Without a common clock a line keeps its frequency and amplitude from run to run but not its phase:
    // each run gets its own sine and cosine (the periodogram already sums runs' powers).
    phases_ = t.machine_time ? 1 : t.runs.size();
    // Two lines closer than the Fourier resolution 1/t_span are one line: the second strongest is sought
    // at least that far from the first.
    apart_ = static_cast<std::size_t>(std::ceil(1.0 / (t_span * df_) - 1e-9));
    // Only the bins up to half the FFT's size are read: the reflected half is not formed.
    fft_.SetFlag(Eigen::FFT<double>::HalfSpectrum);
    // Each sample's bin and projections: the same for every residual the generator is given.
    bin_.reserve(t.g.size());
    for (auto* v : {&weights_[0], &weights_[1], &weights_[2], &step_sin_, &step_cos_}) v->reserve(t.g.size());
    for (std::size_t i = 0, first = 0; i < t.g.size(); ++i) {
      if (t.g[i].run != t.g[first].run) first = i;
      bin_.push_back(static_cast<std::size_t>(std::max(0.0, std::round((t.g[i].t_s - t.g[first].t_s) / dt_))));
      for (int which = 0; which < 3; ++which)
        weights_[static_cast<std::size_t>(which)].push_back(weight(t.g[i], which));
      // The step of half a grid step that refined_frequency() takes between its five points, per sample.
      double sn = 0, cs = 0;
      dbb::fast_sincos(2 * pi * step_hz() * t.g[i].t_s, sn, cs);
      step_sin_.push_back(sn);
      step_cos_.push_back(cs);
    }
    // Time moments of the squared projection per direction and run, for a line's report: the frequency's
    // uncertainty (Cramer-Rao, from the spread of t about each run's centroid: the periodogram that chose
    // it sums runs' powers, so it knows f from within runs only) and, per phase group, the part of it
    // that reaches a phase counted from t = 0.
    for (int which = 0; which < 3; ++which) {
      auto& mom = moments_[static_cast<std::size_t>(which)];
      mom.resize(t.runs.size());
      for (const Geo& p : t.g) {
        const double w = weight(p, which);
        Moments& mo = mom[p.run];
        mo.w2 += w * w;
        mo.w2t += w * w * p.t_s;
        mo.w2t2 += w * w * p.t_s * p.t_s;
      }
    }
  }

  [[nodiscard]] std::size_t grid() const { return grid_; }

  // Held-out rows have residual 0: the periodogram is that of the rows in use.
  [[nodiscard]] std::vector<Variant> variants(const Eigen::VectorXd& r) const {
    const auto pw = periodograms(r);
    std::vector<Variant> vs;
    for (int which = 0; which < 3; ++which)
      for (const std::size_t q : strongest(pw[static_cast<std::size_t>(which)]))
        vs.push_back(line_variant(refined_frequency(q, which, r), which));
    return vs;
  }

 private:
  // One periodogram per direction the vibration may have (the bar, axis A, axis B), each of the residual
  // weighted by that direction's projection on the bar: a vibration of axis A at f reads as
  // lam cos(zeta) sin(2 pi f t), whose plain periodogram peaks at f +- the circling frequency, not at f.
  // Power summed over runs: sum over runs of |sum_i w_i r_i exp(-2 pi i f t_i)|^2.
  [[nodiscard]] std::array<std::vector<double>, 3> periodograms(const Eigen::VectorXd& r) const {
    const auto& gg = *geo_;
    std::array<std::vector<double>, 3> pw;
    for (auto& v : pw) v.assign(grid_, 0.0);
    std::vector<double> binned(fft_size_);
    std::vector<std::complex<double>> spectrum;
    // The FFT's plan (its twiddle factors: a sine and cosine per point) is made once, not per call.
    const std::lock_guard<std::mutex> lock(fft_mutex_);
    for (std::size_t i = 0; i < gg.size();) {
      const std::size_t first = i;
      while (i < gg.size() && gg[i].run == gg[first].run) ++i;
      for (int which = 0; which < 3; ++which) {
        std::fill(binned.begin(), binned.end(), 0.0);
        const std::vector<double>& w = weights_[static_cast<std::size_t>(which)];
        for (std::size_t j = first; j < i; ++j)
          if (bin_[j] < fft_size_) binned[bin_[j]] += w[j] * r[static_cast<Eigen::Index>(j)];
        fft_.fwd(spectrum, binned);
        auto& acc = pw[static_cast<std::size_t>(which)];
        for (std::size_t q = 0; q < grid_; ++q) acc[q] += std::norm(spectrum[q_lo_ + q]);
      }
    }
    return pw;
  }

  [[nodiscard]] double step_hz() const { return 0.5 * df_; }

  // The exact periodogram at f, f + h, ..., f + 4h (direction `which`, h = step_hz()): per sample one phasor
  // at f and the step of h, kept per sample, multiplied on (one sine-cosine pair a sample instead of five).
  [[nodiscard]] std::array<double, 5> powers(double f, int which, const Eigen::VectorXd& r) const {
    const auto& gg = *geo_;
    std::array<double, 5> total{}, re{}, im{};
    const auto flush = [&] {
      for (std::size_t k = 0; k < 5; ++k) {
        total[k] += re[k] * re[k] + im[k] * im[k];
        re[k] = im[k] = 0;
      }
    };
    for (std::size_t j = 0; j < gg.size(); ++j) {
      if (j > 0 && gg[j].run != gg[j - 1].run) flush();
      const double v = weights_[static_cast<std::size_t>(which)][j] * r[static_cast<Eigen::Index>(j)];
      if (v == 0.0) continue;
      double sn = 0, cs = 0;
      dbb::fast_sincos(2 * pi * f * gg[j].t_s, sn, cs);
      const double sh = step_sin_[j], ch = step_cos_[j];
      for (std::size_t k = 0; k < 5; ++k) {
        re[k] += v * cs;
        im[k] -= v * sn;
        const double c2 = cs * ch - sn * sh;
        sn = sn * ch + cs * sh;
        cs = c2;
      }
    }
    flush();
    return total;
  }

  // The strongest grid point, then the strongest at least `apart_` from it.
  [[nodiscard]] std::vector<std::size_t> strongest(const std::vector<double>& at) const {
    std::vector<std::size_t> lines;
    for (int pass = 0; pass < 2; ++pass) {
      std::size_t best = grid_;
      for (std::size_t q = 0; q < grid_; ++q) {
        if (!lines.empty() && (q > lines[0] ? q - lines[0] : lines[0] - q) < apart_) continue;
        if (best == grid_ || at[q] > at[best]) best = q;
      }
      if (best < grid_) lines.push_back(best);
    }
    return lines;
  }

  // Between grid points on the exact periodogram: five points half a grid step apart around the peak,
  // then the parabola through the highest and its neighbours (a coherent fit over runs a minute apart
  // loses much of a line that is a fraction of a grid step off).
  [[nodiscard]] double refined_frequency(std::size_t q, int which, const Eigen::VectorXd& r) const {
    const double f0 = df_ * static_cast<double>(q_lo_ + q), h = step_hz();
    const std::array<double, 5> pk = powers(f0 - 2 * h, which, r);
    const auto top = static_cast<std::size_t>(std::max_element(pk.begin(), pk.end()) - pk.begin());
    double offset = 0.0;
    if (top > 0 && top < 4) {
      const double curvature = pk[top - 1] - 2 * pk[top] + pk[top + 1];
      if (curvature < 0) offset = std::clamp(0.5 * (pk[top - 1] - pk[top + 1]) / curvature, -0.5, 0.5);
    }
    return f0 + (static_cast<double>(top) - 2.0 + offset) * h;
  }

  // The line at f along direction `which`: a sine and a cosine in time (per run without a common clock).
  [[nodiscard]] Variant line_variant(double f, int which) const {
    const std::string along = which == 0 ? "bar" : results::axis_letter(plane_, which - 1);
    const std::size_t phases = phases_;
    std::vector<std::string> names;
    for (std::size_t run_k = 0; run_k < phases; ++run_k) {
      const int run = phases > 1 ? static_cast<int>(run_k + 1) : 0;
      for (const results::Parameter* column : {&results::vibration_sin, &results::vibration_cos})
        names.push_back(run > 0 ? results::run_suffixed(results::name(*column), run) : results::name(*column));
    }
    Variant v = make_lazy_variant(geo_, names, [=](const Geo& p, double* o) {
      const double proj = which == 0 ? 1.0 : p.lambda * (which == 1 ? p.c : p.s);
      const std::size_t col = phases > 1 ? 2 * p.run : 0;
      double sn = 0, cs = 0;
      dbb::fast_sincos(2 * pi * f * p.t_s, sn, cs);
      o[col] = proj * sn;
      o[col + 1] = proj * cs;
    });
    v.searched = 1;
    v.group = along;
    v.report = [along, phases, f, mom = moments_[static_cast<std::size_t>(which)]](const Eigen::VectorXd& x,
                                                                                   const Eigen::MatrixXd& cov) {
      return line_report(along, phases, f, mom, x, cov);
    };
    return v;
  }

  std::shared_ptr<const std::vector<Geo>> geo_;
  double dt_;
  std::string plane_;
  std::size_t fft_size_ = 1;
  double df_ = 0;
  std::size_t q_lo_ = 0, grid_ = 0, phases_ = 1, apart_ = 0;
  std::array<std::vector<Moments>, 3> moments_;
  std::vector<std::size_t> bin_;                // each sample's bin from its run's first
  std::array<std::vector<double>, 3> weights_;  // each sample's projection per direction (weight())
  std::vector<double> step_sin_, step_cos_;     // sin and cos of 2 pi step_hz() t, per sample
  mutable std::mutex fft_mutex_;
  mutable Eigen::FFT<double> fft_;
};

bool vibration_dbb_term(const DbbTerms& t, Candidate& c) {
  // The typical sample interval is the median step: live timestamps jitter, and the smallest step of a
  // real recording can be microseconds, which would put the Nyquist limit absurdly high.
  double t_span = 0, dt = 1e300;
  std::vector<double> steps;
  for (std::size_t i = 1; i < t.g.size(); ++i)
    if (t.g[i].run == t.g[i - 1].run && t.g[i].t_s > t.g[i - 1].t_s) steps.push_back(t.g[i].t_s - t.g[i - 1].t_s);
  if (!steps.empty()) {
    std::nth_element(steps.begin(), steps.begin() + static_cast<std::ptrdiff_t>(steps.size() / 2), steps.end());
    dt = steps[steps.size() / 2];
  }
  for (const auto& r : t.runs) t_span = std::max(t_span, r.t_s.back() - r.t_s.front());
  if (dt < 1e300 && t_span > 0) {
    const auto search = std::make_shared<const LineSearch>(t, dt, t_span);
    c.search_size = 3 * search->grid();
    c.generate = [search](const Eigen::VectorXd& r, const std::vector<bool>&) { return search->variants(r); };
  }
  return true;
}

}  // namespace

extern const Effect vibration{
    {"vibration",
     "a structural or drive vibration at a fixed frequency",
     "time",
     "a sinusoid in time, unrelated to the position",
     {},
     {"dbb"}},
    {"a structural or drive vibration at a fixed frequency, a sinusoid in time unrelated to the position",
     &vibration_dbb_term},
    {}};

}  // namespace guideway::models::explain::effects
