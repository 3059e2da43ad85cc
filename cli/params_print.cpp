#include "cli/params_print.hpp"

#include "cli/daemon_client.hpp"

#include <cmath>
#include <iomanip>
#include <iostream>

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
  if (e.value("unexplained", false)) std::cout << "  a structured residual is left that no effect of the library explains\n";
}

}  // namespace guideway::cli

namespace guideway::cli {

void throw_if_error_reply(const nlohmann::json& reply, bool json) {
  if (json && reply.value("class", "") == "ERROR") std::cout << reply.dump() << "\n" << std::flush;
  throw_if_error(reply);
}

}  // namespace guideway::cli
