// `guideway replay RECORDING...`: a session's raw recording through the same session kind, processing
// steps and identification the daemon ran live (daemon/replay.hpp); prints the PARAMS it published.
#include <cmath>
#include <iostream>
#include <memory>
#include <string>
#include <vector>

#include "cli/commands.hpp"
#include "cli/params_print.hpp"
#include "daemon/replay.hpp"
#include "daemon/session_kinds.hpp"

namespace guideway::cli {

namespace {

// The EXPLAIN message in a few lines (`guideway explain` prints the full report offline).
void print_explanation(const nlohmann::json& e) {
  const auto rms = [](const nlohmann::json& j, const char* k) { return j.contains(k) && j[k].is_number() ? j[k].get<double>() : NAN; };
  std::cout << "explanation (" << e.value("model", "?") << "): held-out rms " << rms(e["baseline"], "heldout_rms_um")
            << " um -> " << rms(e["final"], "heldout_rms_um") << " um\n";
  for (const auto& f : e.value("findings", nlohmann::json::array())) {
    std::cout << "  " << f.value("effect", "?") << ": " << f.value("why", "") << "\n";
  }
  if (e.value("unexplained", false)) std::cout << "  a structured residual is left that no effect of the library explains\n";
}

void add_replay_commands(CLI::App& app, CliContext& ctx) {
  struct Options {
    std::vector<std::string> recordings;
    bool json = false;
  };
  auto o = std::make_shared<Options>();
  auto* replay = app.add_subcommand(
      "replay", "Replay raw session recordings (guideway/raw/1) through the daemon's session code and print their PARAMS");
  replay->add_option("recording", o->recordings, "raw recording files (NAME.csv or an interrupted NAME.csv.part)")
      ->required()
      ->check(CLI::ExistingFile);
  replay->add_flag("--json", o->json, "one PARAMS JSON line per recording, as the daemon published it");
  replay->callback([&ctx, o] {
    daemon::SessionRegistry registry;
    daemon::register_builtin_sessions(registry);
    for (const auto& path : o->recordings) {
      const daemon::ReplayResult r = daemon::replay_recording(path, registry);
      if (!r.failure.empty()) {
        ctx.exit_code = 1;
        if (o->json) {
          std::cout << nlohmann::json{{"class", "EVENT"}, {"event", "session_failed"}, {"reason", r.failure},
                                      {"replayed_from", path}}
                           .dump()
                    << "\n";
        } else {
          std::cerr << "guideway: " << path << ": identification failed: " << r.failure << "\n";
        }
        continue;
      }
      if (o->json) {
        std::cout << r.params.dump() << "\n";
        if (!r.explain.is_null()) std::cout << r.explain.dump() << "\n";
        continue;
      }
      std::cout << "replayed " << path << ": " << r.samples << " samples"
                << (r.complete ? "" : " (incomplete recording: the session was interrupted)") << "\n";
      print_params(r.params);
      if (!r.explain.is_null()) print_explanation(r.explain);
      if (!r.explain_failure.empty()) std::cout << "explanation failed: " << r.explain_failure << "\n";
    }
  });
}

const CommandGroup group(&add_replay_commands);

}  // namespace

}  // namespace guideway::cli
