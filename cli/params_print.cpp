#include "cli/params_print.hpp"

#include "cli/daemon_client.hpp"
#include "cli/instrument_print.hpp"
#include "core/units.hpp"
#include "results/message_class.hpp"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <ctime>
#include <iomanip>
#include <iostream>
#include <sstream>

namespace guideway::cli {

void print_params(const nlohmann::json& p) {
  std::cout << "session " << p.value("session", "?") << " (" << p.value("kind", "?") << " on " << p.value("device", "?")
            << "), model " << p.value("model", "?") << "\n";
  for (const auto& [group, items] : p.items()) {
    if (!items.is_object() || items.empty()) continue;
    bool is_param_group = true;
    for (const auto& [name, v] : items.items()) is_param_group = is_param_group && v.is_object() && v.contains("value");
    if (!is_param_group) continue;
    std::cout << group << ":\n";
    for (const auto& [name, v] : items.items()) {
      std::cout << "  " << std::left << std::setw(28) << name << std::right << std::setw(14) << std::setprecision(6)
                << std::defaultfloat << v["value"].get<double>();
      if (v.contains("u")) std::cout << " +/- " << std::setw(10) << v["u"].get<double>();
      std::cout << "\n";
    }
  }
  for (const char* group : {"fit", "diagnostics_fit"}) {
    if (!p.contains(group) || !p[group].is_object()) continue;
    std::cout << group << ":";
    for (const auto& [k, v] : p[group].items()) {
      if (v.is_primitive()) std::cout << " " << k << "=" << v.dump();
    }
    std::cout << "\n";
    if (p[group].contains("unidentifiable") && !p[group]["unidentifiable"].empty()) {
      std::cout << "  not separable by these patterns:";
      for (const auto& n : p[group]["unidentifiable"]) std::cout << " " << n.get<std::string>();
      std::cout << "\n";
    }
  }
  const nlohmann::json ranking = p.value("ranking", nlohmann::json::array());
  if (!ranking.empty()) {
    std::cout << "what to fix first (each error's part of the circular deviation G, from the "
              << p.value("ranking_model", std::string("?")) << "):\n";
    for (const auto& c : ranking) {
      const nlohmann::json percent = c.value("percent_of_circular_deviation", nlohmann::json());
      std::cout << "  " << std::left << std::setw(28) << c.value("name", std::string("?")) << std::right << std::setw(10)
                << std::setprecision(3) << c.value("contribution_um", 0.0) << " um";
      if (percent.is_number()) std::cout << std::setw(7) << std::setprecision(3) << percent.get<double>() << " % of G";
      std::cout << "\n";
    }
  }
  for (const auto& n : p.value("notes", nlohmann::json::array())) std::cout << "note: " << n.get<std::string>() << "\n";
  if (p.contains("wavelet") && p["wavelet"].contains("bands")) {  // the profile session's summary
    const auto& w = p["wavelet"];
    std::cout << "wavelet " << w.value("wavelet", "?") << ", " << w.value("level", 0) << " levels (dominant detail "
              << w.value("dominant_detail", "?") << "):";
    for (const auto& b : w["bands"]) {
      std::cout << " " << b.value("band", "?") << "=" << std::setprecision(4)
                << (b.contains("rms_um") ? b["rms_um"].get<double>() : b.value("form_um", 0.0)) << "um";
    }
    std::cout << "\n";
  }
  if (p.contains("incomplete")) std::cout << "incomplete: " << p["incomplete"].get<std::string>() << "\n";
  if (p.contains("recording")) std::cout << "recording: " << p["recording"].get<std::string>() << "\n";
  if (p.contains("recording_error")) std::cout << "recording error: " << p["recording_error"].get<std::string>() << "\n";
  for (const auto& f : p.value("derived", nlohmann::json::array())) std::cout << "derived: " << f.get<std::string>() << "\n";
  print_instrument(p, std::cout);
}

void print_explanation(const nlohmann::json& e) {
  // Every lookup by value with a default: a missing key never reaches const operator[] (undefined
  // behaviour), and loops run over named locals, not over items() of a temporary.
  const auto rms = [&e](const char* group) {
    const nlohmann::json g = e.value(group, nlohmann::json::object());
    const nlohmann::json v = g.value("heldout_rms_um", nlohmann::json());
    return v.is_number() ? v.get<double>() : NAN;
  };
  if (e.contains("not_analysed") && e["not_analysed"].is_string()) {
    std::cout << "explanation (" << e.value("model", "?") << " model): not analysed: "
              << e["not_analysed"].get<std::string>() << "\n";
    return;
  }
  std::cout << "explanation (" << e.value("model", "?") << " model): held-out rms " << rms("baseline") << " um -> "
            << rms("final") << " um\n";
  const nlohmann::json findings = e.value("findings", nlohmann::json::array());
  for (const auto& f : findings) {
    std::cout << "  " << f.value("effect", "?");
    const nlohmann::json parameters = f.value("parameters", nlohmann::json::object());
    for (const auto& [name, v] : parameters.items()) {
      const nlohmann::json value = v.value("value", nlohmann::json());
      const nlohmann::json u = v.value("u", nlohmann::json());
      if (!value.is_number()) continue;
      std::cout << "  " << name << " = " << value.get<double>();
      if (u.is_number()) std::cout << " +/- " << u.get<double>();
    }
    std::cout << "\n    " << f.value("why", "") << "\n";
  }
  // Largest first, against the yardstick (a DBB run's circular deviation G).
  std::vector<std::pair<double, std::string>> ranked;
  for (const auto& f : findings) {
    const nlohmann::json c = f.value("contribution_um", nlohmann::json());
    const nlohmann::json pc = f.value("percent_of_deviation", nlohmann::json());
    if (!c.is_number()) continue;
    std::ostringstream line;
    line << f.value("effect", "?") << " " << std::setprecision(3) << c.get<double>() << " um";
    if (pc.is_number()) line << " (" << std::setprecision(2) << pc.get<double>() << " %)";
    ranked.emplace_back(c.get<double>(), line.str());
  }
  std::stable_sort(ranked.begin(), ranked.end(), [](const auto& a, const auto& b) { return a.first > b.first; });
  if (!ranked.empty()) {
    const nlohmann::json dev = e.value("deviation", nlohmann::json::object());
    std::cout << "  largest first";
    if (dev.is_object() && dev.contains("value_um"))
      std::cout << " (of " << dev.value("name", std::string("the deviation")) << " " << std::setprecision(3)
                << dev.value("value_um", 0.0) << " um)";
    std::cout << ":";
    for (const auto& [v, line] : ranked) std::cout << "  " << line << ";";
    std::cout << "\n";
  }
  if (e.value("unexplained", false)) std::cout << "  a structured residual is left that no effect of the library explains\n";
}

void throw_if_error_reply(const nlohmann::json& reply, bool json) {
  if (json && results::has_class(reply, results::MessageClass::error)) std::cout << reply.dump() << "\n" << std::flush;
  throw_if_error(reply);
}

namespace {

std::string number(const nlohmann::json& v) {
  if (!v.is_number()) return v.is_string() ? v.get<std::string>() : v.dump();
  std::ostringstream s;
  s << std::setprecision(6) << v.get<double>();
  return s.str();
}

std::string wall_clock_now() {
  timespec ts{};
  clock_gettime(CLOCK_REALTIME, &ts);
  std::tm tm{};
  localtime_r(&ts.tv_sec, &tm);
  char buf[32];
  const std::size_t n = std::strftime(buf, sizeof(buf), "%H:%M:%S", &tm);
  std::snprintf(buf + n, sizeof(buf) - n, ".%03ld", ts.tv_nsec / 1'000'000);
  return buf;
}

}  // namespace

DisplayUnit display_unit(const std::string& si_unit, double first_value) {
  if (si_unit == "m")
    return std::abs(first_value) >= 1e-3 ? DisplayUnit{"mm", 1e3, 4} : DisplayUnit{"µm", 1e6, 3};
  if (si_unit == "rad") return {"arcsec", 1.0 / rad_per_arcsec, 2};
  return {si_unit == "1" ? std::string() : si_unit, 1.0, -1};
}

std::string watch_line(const nlohmann::json& m, const ChannelUnits& units, ChannelDisplay* display) {
  const std::string cls = m.value("class", "?");
  const std::optional<results::MessageClass> known = results::class_named(cls);
  std::ostringstream out;
  out << wall_clock_now() << " " << std::left << std::setw(7) << cls << std::right;
  // A value with its unit: as the daemon sent it (SI) without `display`, else in the channel's display unit.
  const auto value_of = [&](const std::string& device, const std::string& channel, const nlohmann::json& v) {
    const auto it = units.find(device + "/" + channel);
    const std::string si_unit = it == units.end() ? std::string() : it->second;
    if (display == nullptr || !v.is_number()) return number(v) + (si_unit.empty() || si_unit == "1" ? "" : " " + si_unit);
    auto shown = display->find(device + "/" + channel);
    if (shown == display->end())
      shown = display->emplace(device + "/" + channel, display_unit(si_unit, v.get<double>())).first;
    const DisplayUnit& d = shown->second;
    std::ostringstream s;
    if (d.decimals >= 0)
      s << std::fixed << std::setprecision(d.decimals) << v.get<double>() * d.per_si;
    else
      s << number(v.get<double>() * d.per_si);
    return s.str() + (d.unit.empty() ? "" : " " + d.unit);
  };
  if (known == results::MessageClass::sample) {
    const std::string device = m.value("device", "?");
    out << " " << device << " seq " << m.value("seq", nlohmann::json(0)).dump();
    const nlohmann::json values = m.value("values", nlohmann::json::object());
    for (const auto& [name, v] : values.items()) {
      out << "  " << name << "=" << value_of(device, name, v);
    }
    const nlohmann::json denoised = m.value("denoised", nlohmann::json::object());
    const nlohmann::json denoised_values = denoised.value("values", nlohmann::json::object());
    for (const auto& [name, v] : denoised_values.items()) {
      out << "  " << name << "(denoised, seq " << denoised.value("seq", nlohmann::json(0)).dump()
          << ")=" << value_of(device, name, v);
    }
    if (m.contains("flags")) out << "  flags=" << m["flags"].dump();
  } else if (known == results::MessageClass::status) {
    const nlohmann::json devices = m.value("devices", nlohmann::json::array());
    for (const auto& d : devices) {
      out << " " << d.value("name", "?") << ":" << d.value("state", "?");
      const nlohmann::json c = d.value("counters", nlohmann::json::object());
      const std::uint64_t overruns = c.value("overruns", std::uint64_t{0});
      if (overruns != 0) out << "(overruns " << overruns << ")";
    }
    const nlohmann::json sessions = m.value("sessions", nlohmann::json::array());
    for (const auto& s : sessions) {
      if (s.value("state", "") != "running" && s.value("state", "") != "finishing") continue;
      out << "  session " << s.value("session", "?") << " " << s.value("progress", s.value("state", "?"));
      if (s.contains("recording_error")) out << " [recording error: " << s.value("recording_error", "") << "]";
    }
  } else if (known == results::MessageClass::params) {
    out << " " << m.value("session", "?") << " (" << m.value("model", "?") << ")";
    for (const auto& [group, items] : m.items()) {
      if (!items.is_object() || items.empty()) continue;
      for (const auto& [name, v] : items.items()) {
        if (!v.is_object() || !v.contains("value")) continue;
        out << "  " << name << "=" << number(v["value"]);
        if (v.contains("u")) out << "+/-" << number(v["u"]);
      }
    }
    if (m.contains("recording_error")) out << "  [recording error: " << m.value("recording_error", "") << "]";
  } else if (known == results::MessageClass::explain) {
    out << " " << m.value("session", "?") << " (" << m.value("model", "?") << ")";
    if (m.contains("not_analysed")) {
      out << " not analysed: " << m.value("not_analysed", "");
    } else {
      const auto rms = [&m](const char* group) {
        return number(m.value(group, nlohmann::json::object()).value("heldout_rms_um", nlohmann::json("?")));
      };
      out << " held-out rms " << rms("baseline") << " um -> " << rms("final") << " um; findings:";
      const nlohmann::json findings = m.value("findings", nlohmann::json::array());
      if (findings.empty()) out << " none";
      for (const auto& f : findings) out << " " << f.value("effect", "?");
      if (m.value("unexplained", false)) out << "; a structured residual is left";
    }
  } else if (known == results::MessageClass::event) {
    out << " " << m.value("device", "") << " " << m.value("event", "?");
    if (m.contains("session")) out << " " << m.value("session", "");
    if (m.contains("reason")) out << ": " << m.value("reason", "");
    if (m.contains("file")) out << ": " << m.value("file", "");
  } else if (known == results::MessageClass::error) {
    out << " " << m.value("message", "?");
  } else {
    out << " " << m.dump();  // a class of a later protocol minor version
  }
  return out.str();
}

}  // namespace guideway::cli
