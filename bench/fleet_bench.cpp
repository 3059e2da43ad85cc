// The fleet database on this machine's disk: how many PARAMS messages per second `fleet serve` can
// store (each its own transaction, as it arrives; the golden DBB PARAMS, 4 KB, a new session each), and
// how long the fleet status takes on 50 machines with 100 DBB results each. The 50 x 100 database is
// kept at $TMPDIR/guideway-fleet-bench-50x100.sqlite so `guideway fleet status --db` can be timed on it.
#include <filesystem>
#include <fstream>
#include <sstream>

#include <benchmark/benchmark.h>

#include "core/utc_time.hpp"
#include "fleet/fleet_status.hpp"
#include "fleet/store.hpp"

namespace {

namespace fs = std::filesystem;

// The golden DBB PARAMS split around its session's value, so each message can get its own.
struct Payload {
  std::string head, tail;
  [[nodiscard]] std::string with_session(std::size_t n) const { return head + "bench-" + std::to_string(n) + tail; }
};

Payload golden_dbb() {
  std::ifstream in(std::string(GUIDEWAY_SOURCE_DIR) + "/tests/golden/dbb.params.json");
  std::ostringstream s;
  s << in.rdbuf();
  const std::string text = s.str();
  const std::string key = "\"session\": \"";
  const auto at = text.find(key) + key.size();
  return {text.substr(0, at), text.substr(text.find('"', at))};
}

void BM_IngestParams(benchmark::State& state) {
  const fs::path dir = fs::temp_directory_path() / "guideway-fleet-bench-ingest";
  fs::remove_all(dir);
  guideway::fleet::Store store((dir / "fleet.sqlite").string());
  const Payload p = golden_dbb();
  std::size_t n = 0;
  for (auto _ : state) {
    const auto r = store.ingest("plant", "plant/m" + std::to_string(n % 50) + "/params/dbb", p.with_session(n),
                                "2026-11-26T11:00:00.000Z", "2026-11-26T11:00:00.100Z");
    if (r.outcome != guideway::fleet::IngestResult::stored) state.SkipWithError("not stored");
    ++n;
  }
  state.SetItemsProcessed(static_cast<std::int64_t>(n));
  fs::remove_all(dir);
}
BENCHMARK(BM_IngestParams)->Iterations(10000)->Unit(benchmark::kMicrosecond);

// 50 machines x 100 DBB results, made once.
const std::string& fleet_50x100() {
  static const std::string path = [] {
    const std::string file = (fs::temp_directory_path() / "guideway-fleet-bench-50x100.sqlite").string();
    fs::remove(file);
    guideway::fleet::Store store(file);
    const Payload p = golden_dbb();
    for (std::size_t m = 0; m < 50; ++m)
      for (std::size_t k = 0; k < 100; ++k)
        store.ingest("plant", "plant/m" + std::to_string(m) + "/params/dbb", p.with_session(m * 100 + k),
                     guideway::utc_iso_ms(1.79e9 + static_cast<double>(k) * 6 * 3600), "2026-11-26T11:00:00Z");
    return file;
  }();
  return path;
}

void BM_FleetStatus50x100(benchmark::State& state) {
  const guideway::fleet::Store store(fleet_50x100(), guideway::fleet::Store::Open::existing);
  for (auto _ : state)
    benchmark::DoNotOptimize(guideway::fleet::status_text(guideway::fleet::fleet_status(store, 1.8e9)));
}
BENCHMARK(BM_FleetStatus50x100)->Unit(benchmark::kMillisecond);

}  // namespace

BENCHMARK_MAIN();
