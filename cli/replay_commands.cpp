// `guideway replay RECORDING...`: a session's raw recording through the same session kind, processing
// steps and identification the daemon ran live (sessions/replay.hpp); prints the PARAMS it published.
#include <iostream>
#include <memory>
#include <string>
#include <vector>

#include "cli/commands.hpp"
#include "cli/params_print.hpp"
#include "results/message_class.hpp"
#include "results/result_header.hpp"
#include "sessions/replay.hpp"
#include "sessions/session_kinds.hpp"

namespace guideway::cli {

namespace {

// Why a replayed result may differ from a whole session's (the live daemon published none for it).
std::string incomplete_note(const sessions::ReplayResult& r) {
  if (r.complete) return "";
  if (r.samples_lost > 0) {
    return " (the recording lost " + std::to_string(r.samples_lost) +
           " samples the disk refused: the live session saw them, so its result may differ)";
  }
  if (r.end_marker == "aborted") {
    return " (recording marked aborted: the daemon stopped mid-session, or the live identification failed)";
  }
  return " (incomplete recording: the session was interrupted)";
}

// The PARAMS and EXPLAIN messages of a replay, written from its types as the daemon writes the live session's.
nlohmann::json params_message(const sessions::ReplayResult& r) {
  return results::with_class(results::MessageClass::params,
                             results::with_header(results::to_json(*r.parameters), r.header));
}

nlohmann::json explain_message(const sessions::ReplayResult& r) {
  results::ResultHeader header = r.header;
  header.samples.reset();  // an EXPLAIN names its session, not what it was fed
  return results::with_class(results::MessageClass::explain,
                             results::with_header(results::to_json(*r.explanation), header));
}

struct ReplayArgs {
  std::vector<std::string> recordings;
  bool json = false;
  void add(CLI::App& cmd) {
    cmd.add_option("recording", recordings, "raw recording files (NAME.csv or an interrupted NAME.csv.part)")
        ->required()
        ->check(CLI::ExistingFile);
    cmd.add_flag("--json", json, "one PARAMS JSON line per recording, as the daemon published it");
  }
};

// One recording replayed and printed; false when its identification failed (said on stderr, or as the
// live session's EVENT with --json).
bool replay_one(const std::string& path, const sessions::SessionRegistry& registry, bool json) {
  const sessions::ReplayResult r = sessions::replay_recording(path, registry);
  if (!r.note.empty()) std::cerr << "guideway: " << path << ": note: " << r.note << "\n";
  if (!r.failure.empty()) {
    if (json) {
      std::cout << results::with_class(results::MessageClass::event,
                                       {{"event", "session_failed"}, {"reason", r.failure}, {"replayed_from", path}})
                       .dump()
                << "\n";
    } else {
      std::cerr << "guideway: " << path << ": identification failed: " << r.failure << incomplete_note(r) << "\n";
    }
    return false;
  }
  if (json) {
    std::cout << params_message(r).dump() << "\n";
    if (r.explanation) std::cout << explain_message(r).dump() << "\n";
    return true;
  }
  std::cout << "replayed " << path << ": " << r.samples << " samples" << incomplete_note(r) << "\n";
  print_params(params_message(r));
  if (r.explanation) print_explanation(*r.explanation);
  if (!r.explain_failure.empty()) std::cout << "explanation failed: " << r.explain_failure << "\n";
  return true;
}

void run_replay(const ReplayArgs& a, CliContext& ctx) {
  sessions::SessionRegistry registry;
  sessions::register_builtin_sessions(registry);
  for (const auto& path : a.recordings)
    if (!replay_one(path, registry, a.json)) ctx.exit_code = 1;
}

void add_replay_commands(CLI::App& app, CliContext& ctx) {
  add_commands(app, ctx,
               {command("replay",
                        "Replay raw session recordings (guideway/raw/1) through the daemon's session code and print "
                        "their PARAMS",
                        &run_replay)});
}

const CommandGroup group(&add_replay_commands);

}  // namespace

}  // namespace guideway::cli
