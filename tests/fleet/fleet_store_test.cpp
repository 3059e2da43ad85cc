// fleet/: the store on real SQLite files (golden PARAMS and EXPLAIN of every session kind under two
// machines, duplicates, wills, produced-time order, schema versions), the headline figures read from the
// golden files, the moved flag (k = 2) and the fleet status built from the store.
#include <sqlite3.h>
#include <sys/stat.h>

#include <algorithm>
#include <atomic>
#include <cmath>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <functional>
#include <limits>
#include <random>
#include <set>
#include <sstream>
#include <thread>

#include <gtest/gtest.h>
#include <nlohmann/json.hpp>

#include "fleet/fleet_report.hpp"
#include "fleet/fleet_status.hpp"
#include "fleet/headlines.hpp"
#include "fleet/history.hpp"
#include "fleet/store.hpp"
#include "test_support.hpp"

using namespace guideway::fleet;
using guideway::results::params_from_json;

namespace {

const std::string prefix = "plant/hall1";
const char* const kinds[] = {"dbb", "runout", "straightness", "profile"};

std::string golden(const std::string& name) {
  std::ifstream in(std::string(GUIDEWAY_SOURCE_DIR) + "/tests/golden/" + name);
  std::ostringstream s;
  s << in.rdbuf();
  return s.str();
}
nlohmann::json golden_json(const std::string& name) { return nlohmann::json::parse(golden(name)); }

std::string topic(const std::string& machine, const std::string& leaf, const std::string& kind = {}) {
  return prefix + "/" + machine + "/" + leaf + (kind.empty() ? "" : "/" + kind);
}

const Headline& find(const std::vector<Headline>& hs, const std::string& name) {
  for (const auto& h : hs)
    if (h.name == name) return h;
  throw std::runtime_error("no headline " + name);
}

IngestResult::Outcome put(Store& s, const std::string& t, const std::string& payload, const std::string& produced,
                          const std::string& received = "2026-11-26T12:00:00.000Z") {
  return s.ingest(prefix, t, payload, produced, received).outcome;
}

}  // namespace

TEST(FleetStore, GoldenResultsOfTwoMachinesAreStoredOnceEach) {
  guideway::test::TempDir dir;
  const std::string path = dir.file("state/sub/fleet.sqlite");
  {
    Store s(path);
    for (const std::string machine : {"mill-1", "lathe-2"})
      for (const std::string k : kinds) {
        EXPECT_EQ(put(s, topic(machine, "params", k), golden(k + ".params.json"), "2026-11-20T10:00:00.000Z"),
                  IngestResult::stored);
        EXPECT_EQ(put(s, topic(machine, "explain", k), golden(k + ".explain.json"), "2026-11-20T10:00:01.000Z"),
                  IngestResult::stored);
        // The retained copy on every resubscription, a QoS 1 redelivery: nothing new.
        EXPECT_EQ(put(s, topic(machine, "params", k), golden(k + ".params.json"), "2026-11-20T10:00:00.000Z",
                      "2026-11-26T13:00:00.000Z"),
                  IngestResult::duplicate);
      }
  }
  // Directories made private; the data is on disk for a second opening.
  struct stat st {};
  ASSERT_EQ(::stat((dir.path() / "state").c_str(), &st), 0);
  EXPECT_EQ(st.st_mode & 0777, 0700u);
  const Store s(path, Store::Open::existing);
  ASSERT_EQ(s.machines().size(), 2u);
  EXPECT_EQ(s.machines()[0].machine, "lathe-2");
  EXPECT_EQ(s.results("mill-1").size(), 8u);
  EXPECT_EQ(s.results("mill-1", "dbb").size(), 2u);
  const auto p = s.results("lathe-2", "runout", "PARAMS");
  ASSERT_EQ(p.size(), 1u);
  EXPECT_EQ(p[0].session, "runout-micrometer-20261127T090008Z");
  EXPECT_EQ(p[0].produced_utc, "2026-11-20T10:00:00.000Z");
  EXPECT_EQ(p[0].received_utc, "2026-11-26T12:00:00.000Z");
  EXPECT_EQ(p[0].payload, golden("runout.params.json"));
  EXPECT_EQ(s.machines()[1].last_seen_utc, "2026-11-26T13:00:00.000Z");
}

TEST(FleetStore, EventsDevicesAndWhatIsIgnored) {
  guideway::test::TempDir dir;
  Store s(dir.file("fleet.sqlite"));
  const std::string ev = R"({"class":"EVENT","time":"2026-11-26T11:00:00Z","event":"session_complete"})";
  EXPECT_EQ(put(s, topic("m", "event"), ev, "2026-11-26T11:00:00.100Z"), IngestResult::stored);
  EXPECT_EQ(put(s, topic("m", "event"), ev, "2026-11-26T11:00:00.100Z"), IngestResult::duplicate);
  EXPECT_EQ(s.events("m").size(), 1u);
  EXPECT_EQ(put(s, topic("d", "devices"), R"({"class":"STATUS"})", "", "2026-11-26T11:00:05.000Z"),
            IngestResult::stored);
  ASSERT_EQ(s.machines().size(), 2u);
  EXPECT_EQ(s.machines()[0].last_seen_utc, "2026-11-26T11:00:05.000Z");
  EXPECT_TRUE(s.results("d").empty());

  const auto r = s.ingest(prefix, "other/m/params/dbb", "{}", "", "2026-11-26T11:00:00Z");
  EXPECT_EQ(r.outcome, IngestResult::refused);
  EXPECT_NE(r.reason.find("not our topic tree"), std::string::npos);
  EXPECT_NE(
      s.ingest(prefix, topic("x", "params", "dbb"), "{not json", "", "2026-11-26T11:00:00Z").reason.find("not JSON"),
      std::string::npos);
  EXPECT_EQ(put(s, topic("x", "explain", "dbb"), golden("dbb.params.json"), ""), IngestResult::refused);  // a PARAMS
  EXPECT_EQ(put(s, topic("x", "status"), R"({"state":"online","machine":"y"})", ""), IngestResult::refused);
  // A device table that is not JSON (docs/plant.md: leaves no trace) makes no machine either.
  EXPECT_EQ(put(s, topic("phantom", "devices"), "not json at all", ""), IngestResult::refused);
  EXPECT_EQ(s.machines().size(), 2u);  // a refused message leaves no machine behind
  EXPECT_EQ(s.refused_count(), 5);
  const auto newest = s.refusals(2);
  ASSERT_EQ(newest.size(), 2u);
  EXPECT_EQ(newest[1].machine, "phantom");
  EXPECT_EQ(newest[1].topic, topic("phantom", "devices"));
  EXPECT_EQ(newest[1].size_bytes, 15);
}

TEST(FleetStore, StatusOnlineThenWillWithoutTimeThenStopped) {
  guideway::test::TempDir dir;
  Store s(dir.file("fleet.sqlite"));
  const std::string online = R"({"state":"online","machine":"m","release":"0.1.0","since":"2026-11-26T11:00:00Z"})";
  const std::string will = R"({"state":"offline","machine":"m","reason":"connection lost"})";
  EXPECT_EQ(put(s, topic("m", "status"), online, "2026-11-26T11:00:00.010Z", "2026-11-26T11:00:00.020Z"),
            IngestResult::stored);
  EXPECT_EQ(put(s, topic("m", "status"), online, "2026-11-26T11:00:00.010Z", "2026-11-26T11:05:00.000Z"),
            IngestResult::duplicate);
  auto m = s.machines().at(0);
  EXPECT_EQ(m.state, "online");
  EXPECT_EQ(m.since, "2026-11-26T11:00:00.000Z");
  EXPECT_EQ(m.release, "0.1.0");
  // The will: no time of its own, so since = when it arrived (its produced_utc was stamped at connect).
  EXPECT_EQ(put(s, topic("m", "status"), will, "2026-11-26T11:00:00.000Z", "2026-11-26T11:30:00.250Z"),
            IngestResult::stored);
  m = s.machines().at(0);
  EXPECT_EQ(m.state, "offline");
  EXPECT_EQ(m.since, "2026-11-26T11:30:00.250Z");
  EXPECT_EQ(m.reason, "connection lost");
  // Its retained copy on resubscription changes nothing.
  EXPECT_EQ(put(s, topic("m", "status"), will, "", "2026-11-26T12:00:00.000Z"), IngestResult::duplicate);
  EXPECT_EQ(s.machines().at(0).since, "2026-11-26T11:30:00.250Z");
  // A status older than the one applied (delivered late) does not undo it.
  const std::string stale = R"({"state":"online","machine":"m","release":"0.0.9","since":"2026-11-26T10:00:00Z"})";
  EXPECT_EQ(put(s, topic("m", "status"), stale, ""), IngestResult::ignored);
  EXPECT_EQ(s.machines().at(0).state, "offline");
  const std::string stopped = R"({"state":"offline","machine":"m","since":"2026-11-26T12:10:00Z","reason":"stopped"})";
  EXPECT_EQ(put(s, topic("m", "status"), stopped, ""), IngestResult::stored);
  EXPECT_EQ(s.machines().at(0).reason, "stopped");
  EXPECT_EQ(s.machines().at(0).since, "2026-11-26T12:10:00.000Z");
}

TEST(FleetStore, AWillAppliesWhateverTheClockSkew) {
  guideway::test::TempDir dir;
  Store s(dir.file("fleet.sqlite"));
  // The daemon's clock is 5 minutes ahead of this host's.
  const std::string online = R"({"state":"online","machine":"m","release":"0.1.0","since":"2026-11-26T11:05:00Z"})";
  EXPECT_EQ(put(s, topic("m", "status"), online, "", "2026-11-26T11:00:01Z"), IngestResult::stored);
  EXPECT_EQ(put(s, topic("m", "status"), R"({"state":"offline","machine":"m","reason":"connection lost"})", "",
                "2026-11-26T11:02:00Z"),
            IngestResult::stored);
  EXPECT_EQ(s.machines().at(0).state, "offline");
  EXPECT_EQ(s.machines().at(0).since, "2026-11-26T11:02:00.000Z");
  // It reconnects a minute later (its clock: 11:08): online again, although 11:08 > 11:02 only by skew.
  const std::string again = R"({"state":"online","machine":"m","release":"0.1.0","since":"2026-11-26T11:08:00Z"})";
  EXPECT_EQ(put(s, topic("m", "status"), again, "", "2026-11-26T11:03:00Z"), IngestResult::stored);
  EXPECT_EQ(s.machines().at(0).state, "online");
  // The same online status as before the will (a daemon that keeps its start time) applies too.
  EXPECT_EQ(put(s, topic("m", "status"), R"({"state":"offline","machine":"m","reason":"connection lost"})", "",
                "2026-11-26T11:04:00Z"),
            IngestResult::stored);
  EXPECT_EQ(put(s, topic("m", "status"), again, "", "2026-11-26T11:05:00Z"), IngestResult::stored);
  EXPECT_EQ(s.machines().at(0).state, "online");
  EXPECT_EQ(s.machines().at(0).since, "2026-11-26T11:08:00.000Z");
}

TEST(FleetStore, ResultsAreOrderedByProducedTimeNotArrival) {
  guideway::test::TempDir dir;
  Store s(dir.file("fleet.sqlite"));
  auto p = golden_json("dbb.params.json");
  const auto with_session = [&](const std::string& session) {
    p["session"] = session;
    return p.dump();
  };
  // After a broker outage the older result arrives last; the same second with and without milliseconds.
  EXPECT_EQ(put(s, topic("m", "params", "dbb"), with_session("c"), "2026-11-22T08:00:00Z"), IngestResult::stored);
  EXPECT_EQ(put(s, topic("m", "params", "dbb"), with_session("b"), "2026-11-21T08:00:00.5Z"), IngestResult::stored);
  EXPECT_EQ(put(s, topic("m", "params", "dbb"), with_session("a"), "2026-11-21T08:00:00Z"), IngestResult::stored);
  // No produced_utc (or one that cannot be read): the receive time stands in.
  EXPECT_EQ(put(s, topic("m", "params", "dbb"), with_session("d"), "", "2026-11-23T00:00:00Z"), IngestResult::stored);
  EXPECT_EQ(put(s, topic("m", "params", "dbb"), with_session("e"), "yesterday", "2026-11-24T00:00:00Z"),
            IngestResult::stored);
  std::string order;
  for (const auto& r : s.results("m")) order += r.session;
  EXPECT_EQ(order, "abcde");
  EXPECT_EQ(s.results("m")[1].produced_utc, "2026-11-21T08:00:00.500Z");
  EXPECT_EQ(s.results("m")[3].produced_utc, "2026-11-23T00:00:00.000Z");
  // The newest two per kind, oldest first.
  const auto latest = s.latest_results(2);
  ASSERT_EQ(latest.size(), 2u);
  EXPECT_EQ(latest[0].session + latest[1].session, "de");
}

TEST(FleetStore, StatusReadsWhileServeWrites) {
  guideway::test::TempDir dir;
  const std::string path = dir.file("fleet.sqlite");
  Store writer(path);
  auto p = golden_json("dbb.params.json");
  std::atomic<bool> done{false};
  std::string reader_error;
  std::size_t reads = 0;
  std::thread reader([&] {
    try {
      const Store r(path, Store::Open::existing);  // its own connection, as `guideway fleet status`
      while (!done.load()) {
        (void)fleet_status(r, 1.8e9);
        ++reads;
      }
    } catch (const std::exception& e) {
      reader_error = e.what();
    }
  });
  for (int i = 0; i < 300; ++i) {
    p["session"] = "s" + std::to_string(i);
    ASSERT_EQ(put(writer, topic("m" + std::to_string(i % 5), "params", "dbb"), p.dump(), ""), IngestResult::stored);
  }
  done = true;
  reader.join();
  EXPECT_EQ(reader_error, "");
  EXPECT_GT(reads, 0u);
  EXPECT_EQ(writer.results("m3").size(), 60u);
}

TEST(FleetStore, NewerSchemaAndForeignDatabasesAreRefused) {
  guideway::test::TempDir dir;
  const std::string path = dir.file("fleet.sqlite");
  try {
    Store s(path, Store::Open::existing);
    FAIL() << "opened a missing database";
  } catch (const std::runtime_error& e) {
    EXPECT_EQ(std::string(e.what()), "no fleet database at " + path + ": start `guideway fleet serve` first");
  }
  { Store s(path); }
  sqlite3* db = nullptr;
  ASSERT_EQ(sqlite3_open(path.c_str(), &db), SQLITE_OK);
  ASSERT_EQ(sqlite3_exec(db, "PRAGMA user_version=7", nullptr, nullptr, nullptr), SQLITE_OK);
  sqlite3_close(db);
  try {
    Store s(path);
    FAIL() << "opened a newer schema";
  } catch (const std::runtime_error& e) {
    EXPECT_NE(std::string(e.what()).find("schema is version 7, newer than this guideway knows (2)"), std::string::npos)
        << e.what();
  }
  const std::string other = dir.file("other.sqlite");
  ASSERT_EQ(sqlite3_open(other.c_str(), &db), SQLITE_OK);
  ASSERT_EQ(sqlite3_exec(db, "CREATE TABLE t(x)", nullptr, nullptr, nullptr), SQLITE_OK);
  sqlite3_close(db);
  EXPECT_THROW(Store{other}, std::runtime_error);
  std::ofstream(dir.file("text.sqlite")) << "this is not a database, it is a text file of some length......\n";
  EXPECT_THROW(Store{dir.file("text.sqlite")}, std::runtime_error);
}

TEST(FleetStore, DefaultPathFollowsSystemdThenXdg) {
  ::setenv("STATE_DIRECTORY", "/var/lib/guideway:/var/lib/other", 1);
  EXPECT_EQ(default_database_path(), "/var/lib/guideway/fleet.sqlite");
  ::unsetenv("STATE_DIRECTORY");
  ::setenv("XDG_STATE_HOME", "/home/u/.st", 1);
  EXPECT_EQ(default_database_path(), "/home/u/.st/guideway/fleet.sqlite");
  ::unsetenv("XDG_STATE_HOME");
}

TEST(FleetHeadlines, FromTheGoldenResults) {
  const auto dbb = headlines("dbb", params_from_json(golden_json("dbb.params.json")));
  ASSERT_EQ(dbb.size(), 3u);  // G, and backlash from lai3: the golden run gives no ballbar diagnostics
  EXPECT_EQ(dbb[0].name, "circular_deviation_um");
  EXPECT_DOUBLE_EQ(dbb[0].value, 17.417894088049465);
  EXPECT_FALSE(dbb[0].u);
  // Backlash from Lai's model (the golden run has no diagnostics), as the golden PARAMS hold it.
  const auto dbb_lai = golden_json("dbb.params.json")["lai3"];
  EXPECT_DOUBLE_EQ(find(dbb, "backlash_x_um").value, dbb_lai["backlash_x_um"]["value"].get<double>());
  EXPECT_DOUBLE_EQ(*find(dbb, "backlash_x_um").u, dbb_lai["backlash_x_um"]["u"].get<double>());
  EXPECT_DOUBLE_EQ(find(dbb, "backlash_y_um").value, dbb_lai["backlash_y_um"]["value"].get<double>());
  EXPECT_NEAR(find(dbb, "backlash_x_um").value, 1.0, 0.01);  // the emulated machine's 1 um

  const auto runout = headlines("runout", params_from_json(golden_json("runout.params.json")));
  const auto squareness = golden_json("runout.params.json")["squareness"];
  EXPECT_DOUBLE_EQ(find(runout, "squareness_urad").value, squareness["squareness_urad"]["value"].get<double>());
  EXPECT_DOUBLE_EQ(*find(runout, "squareness_urad").u, squareness["squareness_urad"]["u"].get<double>());
  EXPECT_DOUBLE_EQ(find(runout, "runout_um").value, squareness["runout_um"]["value"].get<double>());
  EXPECT_NEAR(find(runout, "runout_um").value, 0.3, 0.01);  // the emulated spindle's 0.3 um

  const auto st = headlines("straightness", params_from_json(golden_json("straightness.params.json")));
  ASSERT_EQ(st.size(), 2u);
  EXPECT_DOUBLE_EQ(find(st, "horizontal_straightness_um").value, 0.02703768606187836);
  EXPECT_DOUBLE_EQ(*find(st, "horizontal_straightness_um").u, 0.2312513228037677);
  EXPECT_DOUBLE_EQ(find(st, "vertical_straightness_um").value, 0.07891808072092471);
  EXPECT_DOUBLE_EQ(*find(st, "vertical_straightness_um").u, 0.19924894888793224);

  const auto pr = headlines("profile", params_from_json(golden_json("profile.params.json")));
  EXPECT_DOUBLE_EQ(find(pr, "straightness_lsq_um").value, 0.2055772949384913);
  EXPECT_DOUBLE_EQ(*find(pr, "straightness_lsq_um").u, 0.0290585618977036);
  EXPECT_DOUBLE_EQ(find(pr, "form_straightness_um").value, 0.05332820189032894);
  EXPECT_TRUE(headlines("flatness", params_from_json(golden_json("profile.params.json"))).empty());
}

TEST(FleetHeadlines, DbbDiagnosticsComeFirstAndNameThePlaneAxes) {
  auto p = golden_json("dbb.params.json");
  p["plane"] = "zx";
  p["diagnostics"]["squareness_urad"] = {{"value", 12.5}, {"u", 0.4}};
  p["diagnostics"]["backlash_z_um"] = {{"value", 3.25}, {"u", 0.05}};
  p["diagnostics"]["scale_x_ppm"] = {{"value", -8.0}, {"u", 0.3}};
  p["lai3"]["backlash_z_um"] = p["lai3"]["backlash_x_um"];
  const auto h = headlines("dbb", params_from_json(p));
  EXPECT_DOUBLE_EQ(find(h, "squareness_urad").value, 12.5);
  EXPECT_DOUBLE_EQ(find(h, "backlash_z_um").value, 3.25);  // diagnostics before lai3
  EXPECT_EQ(find(h, "backlash_z_um").label, "backlash Z");
  EXPECT_DOUBLE_EQ(find(h, "scale_x_ppm").value, -8.0);
  EXPECT_THROW(find(h, "scale_z_ppm"), std::runtime_error);  // absent: not listed
}

TEST(FleetHeadlines, ExplainFindings) {
  const auto s = guideway::results::explanation_from_json(golden_json("dbb.explain.json"));
  ASSERT_EQ(s.findings.size(), 2u);
  EXPECT_EQ(s.findings[0].effect, "backlash");
  EXPECT_DOUBLE_EQ(s.findings[0].contribution_um, 1.9898527045693912);
  EXPECT_EQ(s.findings[1].effect, "vibration");
  EXPECT_FALSE(s.unexplained);
  EXPECT_EQ(found_text(s), "backlash 1.99 µm, vibration 0.0246 µm");
  // The run-out's: the example spindle's four error motions, in words and largest first in the text.
  const auto r = guideway::results::explanation_from_json(golden_json("runout.explain.json"));
  EXPECT_FALSE(r.unexplained);
  ASSERT_EQ(r.findings.size(), 4u);
  EXPECT_EQ(found_text(r),  // EXPLAIN selected the drift last; the text ranks it by its size
            "synchronous harmonic 0.239 \u00b5m, asynchronous line 0.16 \u00b5m, thermal drift 0.1 \u00b5m, "
            "synchronous harmonic 0.0975 \u00b5m");
  const auto t = guideway::results::explanation_from_json(golden_json("straightness.explain.json"));
  EXPECT_TRUE(t.unexplained);
  EXPECT_TRUE(t.findings.empty());
  EXPECT_EQ(found_text(t), "not analysed");
}

TEST(FleetHeadlines, MovedBeyondTwiceTheCombinedUncertainty) {
  const Headline prev{"b", "b", "µm", 1.0, 0.03};
  // 2*sqrt(0.03^2 + 0.04^2) = 0.1
  EXPECT_TRUE(moved({"b", "b", "µm", 1.11, 0.04}, prev));
  EXPECT_FALSE(moved({"b", "b", "µm", 1.09, 0.04}, prev));
  EXPECT_TRUE(moved({"b", "b", "µm", 0.89, 0.04}, prev));
  // Without u on either side: never flagged, however far.
  EXPECT_FALSE(moved({"b", "b", "µm", 100.0, std::nullopt}, prev));
  EXPECT_FALSE(moved({"b", "b", "µm", 100.0, 0.04}, {"b", "b", "µm", 1.0, std::nullopt}));
}

TEST(FleetStatus, LatestFiguresAgeAndMovedFlags) {
  guideway::test::TempDir dir;
  Store s(dir.file("fleet.sqlite"));
  auto p = golden_json("dbb.params.json");
  const auto put_dbb = [&](const std::string& session, double backlash_x, double g, const std::string& produced) {
    p["session"] = session;
    p["lai3"]["backlash_x_um"]["value"] = backlash_x;
    p["diagnostics"]["circular_deviation_um"]["value"] = g;
    return put(s, topic("m", "params", "dbb"), p.dump(), produced);
  };
  put_dbb("s1", 1.00, 17.0, "2026-11-20T00:00:00Z");
  put_dbb("s2", 1.50, 10.0, "2026-11-24T00:00:00Z");  // backlash moved, G too but it has no u
  put_dbb("s3", 1.51, 30.0, "2026-11-25T00:00:00Z");  // backlash within 2u of s2
  put(s, topic("m", "explain", "dbb"), golden("dbb.explain.json"), "2026-11-25T00:00:01Z");
  put(s, topic("m", "status"), R"({"state":"online","machine":"m","release":"0.1.0","since":"2026-11-26T11:00:00Z"})",
      "");
  const double now = 1795694400.0;  // 2026-11-26T12:00:00Z
  auto status = fleet_status(s, now);
  ASSERT_EQ(status.size(), 1u);
  const auto& m = status[0];
  EXPECT_EQ(m.machine.state, "online");
  ASSERT_TRUE(m.dbb_age_s);
  EXPECT_DOUBLE_EQ(*m.dbb_age_s, 36 * 3600.0);
  ASSERT_EQ(m.latest.size(), 1u);
  EXPECT_EQ(m.latest[0].session, "s3");
  const auto fig = [&](const std::string& name) {
    for (const auto& f : m.latest[0].figures)
      if (f.latest.name == name) return f;
    throw std::runtime_error(name);
  };
  EXPECT_FALSE(fig("backlash_x_um").moved);
  EXPECT_DOUBLE_EQ(fig("backlash_x_um").previous->value, 1.50);
  EXPECT_FALSE(fig("circular_deviation_um").moved);  // 10 -> 30 um, but G has no u
  ASSERT_EQ(m.explains.size(), 1u);
  EXPECT_EQ(m.explains[0].summary.findings.size(), 2u);
  // History: s2's backlash moved against s1.
  const auto h = history_of(s.results("m", "dbb", "PARAMS"));
  ASSERT_EQ(h.size(), 3u);
  EXPECT_TRUE(h[1].figures[1].moved);
  EXPECT_EQ(h[1].figures[1].latest.name, "backlash_x_um");
  const auto text = status_text(status);
  EXPECT_NE(text.find("backlash X/µm"), std::string::npos) << text;
  EXPECT_NE(text.find("36.0 h ago"), std::string::npos) << text;
  EXPECT_NE(text.find("k = 2"), std::string::npos) << text;
  const auto j = status_json(status);
  EXPECT_EQ(j["machines"][0]["latest"]["dbb"]["session"], "s3");
  EXPECT_EQ(j["machines"][0]["explain"]["dbb"]["findings"][0]["effect"], "backlash");
}

namespace {

// The bytes of a file, "" when it is missing.
std::string bytes_of(const std::string& path) {
  std::ifstream in(path, std::ios::binary);
  std::ostringstream s;
  s << in.rdbuf();
  return s.str();
}

// Everything a reader of the fleet does, as `fleet status`, `history` and `report` do it (the report,
// the slowest, when asked).
void read_everything(const Store& s, bool with_report = true) {
  const auto status = fleet_status(s, 1795694400.0);
  (void)status_text(status);
  (void)status_json(status).dump();
  (void)refusals_text(s);
  for (const auto& m : s.machines()) {
    const auto h = history_of(s.results(m.machine));
    (void)history_text(m.machine, h);
    (void)history_json(m.machine, h).dump();
  }
  if (with_report) (void)render_fleet_report(s, FleetReportOptions{});
}

}  // namespace

TEST(FleetIngest, MalformedResultsAreRefusedCountedAndTheViewKeepsAnswering) {
  guideway::test::TempDir dir;
  Store s(dir.file("fleet.sqlite"));
  EXPECT_EQ(put(s, topic("m", "params", "dbb"), golden("dbb.params.json"), "2026-11-20T10:00:00Z"),
            IngestResult::stored);
  auto params = golden_json("dbb.params.json");
  params["plane"] = "~x";  // made every reader throw parse_error.108 (json pointer "/~_")
  auto bad_figure = golden_json("dbb.params.json");
  bad_figure["diagnostics"]["circular_deviation_um"]["value"] = "17 um";
  const std::vector<std::pair<std::string, std::string>> cases = {
      {topic("m", "explain", "dbb"), R"({"findings":[{"effect":5}]})"},  // type_error.302 in every reader
      {topic("m", "explain", "dbb"), R"({"findings":[{"effect":"backlash","contribution_um":"big"}]})"},
      {topic("m", "explain", "dbb"), R"({"findings":{"effect":"backlash"}})"},
      {topic("m", "explain", "dbb"), R"({"findings":[],"unexplained":"yes"})"},
      {topic("m", "params", "dbb"), params.dump()},
      {topic("m", "params", "dbb"), bad_figure.dump()},
      {topic("m", "params", "dbb"), R"({"session":7})"},
      {topic("m", "status"), R"({"state":"online","since":12})"},
      {topic("m", "params", "dbb"), "[1,2,3]"},
  };
  for (const auto& [t, payload] : cases) {
    const auto r = s.ingest(prefix, t, payload, "", "2026-11-26T12:00:00Z");
    EXPECT_EQ(r.outcome, IngestResult::refused) << payload;
    EXPECT_FALSE(r.reason.empty());
  }
  EXPECT_EQ(s.refused_count(), static_cast<std::int64_t>(cases.size()));
  EXPECT_EQ(s.results("m").size(), 1u);  // none of them stored
  EXPECT_NO_THROW(read_everything(s));
  EXPECT_NE(refusals_text(s).find("refused at ingest: 9 message(s)"), std::string::npos) << refusals_text(s);
  EXPECT_NE(s.refusals(9)[0].reason.find("findings[0] needs \"effect\" as a text"), std::string::npos);
  EXPECT_NE(s.refusals(9)[4].reason.find("\"plane\""), std::string::npos);
}

TEST(FleetIngest, RowsStoredBeforeIngestCheckedAreSkippedNeverFatal) {
  guideway::test::TempDir dir;
  const std::string path = dir.file("fleet.sqlite");
  {
    Store s(path);
    put(s, topic("m", "params", "dbb"), golden("dbb.params.json"), "2026-11-20T10:00:00Z");
  }
  sqlite3* db = nullptr;
  ASSERT_EQ(sqlite3_open(path.c_str(), &db), SQLITE_OK);
  for (const char* payload : {R"({"findings":[{"effect":5}]})", R"({"plane":"~x","diagnostics":{}})", "not json"}) {
    const std::string cls = std::string(payload).find("findings") != std::string::npos ? "EXPLAIN" : "PARAMS";
    const std::string sql =
        "INSERT INTO results(machine, kind, class, produced_utc, received_utc, session, payload, "
        "digest) VALUES('m', 'dbb', '" +
        cls +
        "', '2026-11-21T00:00:00.000Z', "
        "'2026-11-21T00:00:00.000Z', 's', '" +
        payload + "', 0)";
    ASSERT_EQ(sqlite3_exec(db, sql.c_str(), nullptr, nullptr, nullptr), SQLITE_OK);
  }
  sqlite3_close(db);
  const Store s(path, Store::Open::existing);
  EXPECT_NO_THROW(read_everything(s));
  const auto h = history_of(s.results("m"));
  ASSERT_EQ(h.size(), 4u);
  EXPECT_TRUE(h[0].readable);
  // "not json", and the finding whose effect is a number: not an explanation (results::explanation_from_json).
  EXPECT_EQ(std::count_if(h.begin(), h.end(), [](const HistoryEntry& e) { return !e.readable; }), 2);
  EXPECT_NE(history_text("m", h).find("could not be read: skipped"), std::string::npos);
}

TEST(FleetIngest, TimesOutsideBeliefAreReplacedByTheReceiveTimeAndKept) {
  guideway::test::TempDir dir;
  Store s(dir.file("fleet.sqlite"));
  auto p = golden_json("dbb.params.json");
  const auto put_session = [&](const std::string& session, const std::string& produced, const std::string& received) {
    p["session"] = session;
    return s.ingest(prefix, topic("m", "params", "dbb"), p.dump(), produced, received);
  };
  // Produced in 0999: it sorted after 2026 as text and stayed the latest result forever.
  const auto old = put_session("s-0999", "0999-01-01T00:00:00Z", "2026-11-26T10:00:00.000Z");
  EXPECT_EQ(old.outcome, IngestResult::stored);
  EXPECT_NE(old.reason.find("not believed"), std::string::npos);
  put_session("s-9999", "9999-12-31T23:59:59Z", "2026-11-26T10:30:00.000Z");  // and the future froze it
  put_session("s-real", "2026-11-26T11:00:00.000Z", "2026-11-26T11:00:01.000Z");
  const auto rows = s.results("m");
  ASSERT_EQ(rows.size(), 3u);
  EXPECT_EQ(rows[0].session, "s-0999");
  EXPECT_EQ(rows[0].produced_utc, "2026-11-26T10:00:00.000Z");
  EXPECT_EQ(rows[0].claimed_utc, "0999-01-01T00:00:00Z");
  EXPECT_EQ(rows[1].claimed_utc, "9999-12-31T23:59:59Z");
  EXPECT_EQ(rows[2].session, "s-real");
  EXPECT_EQ(rows[2].claimed_utc, "");
  EXPECT_EQ(fleet_status(s, 1795694400.0).at(0).latest.at(0).session, "s-real");
  // A day of clock skew is believed.
  put_session("s-skew", "2026-11-27T10:00:00.000Z", "2026-11-26T11:00:00.000Z");
  EXPECT_EQ(s.results("m").back().produced_utc, "2026-11-27T10:00:00.000Z");

  // Status: a since in 9999 froze the machine (every later status was "older"); 0999 won over 2026.
  const auto status = [&](const std::string& state, const std::string& since, const std::string& received) {
    return put(s, topic("n", "status"), R"({"state":")" + state + R"(","since":")" + since + R"("})", "", received);
  };
  EXPECT_EQ(status("online", "9999-01-01T00:00:00Z", "2026-11-26T10:00:00.000Z"), IngestResult::stored);
  EXPECT_EQ(s.machines().back().since, "2026-11-26T10:00:00.000Z");
  EXPECT_EQ(status("offline", "2026-11-26T10:05:00Z", "2026-11-26T10:05:00.100Z"), IngestResult::stored);
  EXPECT_EQ(s.machines().back().state, "offline");
  EXPECT_EQ(status("online", "0999-01-01T00:00:00Z", "2026-11-26T10:06:00.000Z"), IngestResult::stored);
  EXPECT_EQ(s.machines().back().since, "2026-11-26T10:06:00.000Z");
  EXPECT_EQ(status("offline", "2026-11-26T10:10:00Z", "2026-11-26T10:10:00.100Z"), IngestResult::stored);
  EXPECT_EQ(s.machines().back().state, "offline");
  EXPECT_EQ(s.machines().back().since, "2026-11-26T10:10:00.000Z");
}

TEST(FleetIngest, AVersion1DatabaseIsUpgradedWithItsPoisonedTimesMovedAside) {
  guideway::test::TempDir dir;
  const std::string path = dir.file("fleet.sqlite");
  sqlite3* db = nullptr;
  ASSERT_EQ(sqlite3_open(path.c_str(), &db), SQLITE_OK);
  // Version 1 as fleet serve wrote it, with what a 0999 and a 9999 clock left in it.
  ASSERT_EQ(sqlite3_exec(db, R"sql(
CREATE TABLE machines(machine TEXT PRIMARY KEY, state TEXT NOT NULL DEFAULT '', since TEXT NOT NULL DEFAULT '',
  release TEXT NOT NULL DEFAULT '', reason TEXT NOT NULL DEFAULT '', status_payload TEXT NOT NULL DEFAULT '',
  status_clock TEXT NOT NULL DEFAULT '', last_seen_utc TEXT NOT NULL DEFAULT '');
CREATE TABLE results(id INTEGER PRIMARY KEY, machine TEXT NOT NULL, kind TEXT NOT NULL, class TEXT NOT NULL,
  produced_utc TEXT NOT NULL, received_utc TEXT NOT NULL, session TEXT NOT NULL, payload TEXT NOT NULL,
  digest INTEGER NOT NULL);
CREATE TABLE events(id INTEGER PRIMARY KEY, machine TEXT NOT NULL, produced_utc TEXT NOT NULL,
  received_utc TEXT NOT NULL, payload TEXT NOT NULL, digest INTEGER NOT NULL);
INSERT INTO machines VALUES('m', 'online', '9999-01-01T00:00:00.000Z', '0.1.0', '', '{}',
  '9999-01-01T00:00:00.000Z', '2026-11-26T10:00:00.000Z');
INSERT INTO results VALUES(1, 'm', 'dbb', 'PARAMS', '999-01-01T00:00:00.000Z', '2026-11-26T10:00:00.000Z', 'a', '{}', 1);
INSERT INTO results VALUES(2, 'm', 'dbb', 'PARAMS', '2026-11-25T10:00:00.000Z', '2026-11-26T10:00:00.000Z', 'b', '{}', 2);
PRAGMA user_version=1;
)sql",
                         nullptr, nullptr, nullptr),
            SQLITE_OK);
  sqlite3_close(db);
  { Store upgrade(path); }
  const Store s(path, Store::Open::existing);
  const auto rows = s.results("m");
  ASSERT_EQ(rows.size(), 2u);
  EXPECT_EQ(rows[0].session, "b");  // 0999 no longer sorts after 2026
  EXPECT_EQ(rows[1].produced_utc, "2026-11-26T10:00:00.000Z");
  EXPECT_EQ(rows[1].claimed_utc, "999-01-01T00:00:00.000Z");
  EXPECT_EQ(s.machines().at(0).since, "2026-11-26T10:00:00.000Z");
  EXPECT_EQ(s.refused_count(), 0);
}

TEST(FleetIngest, ForeignAndNewerFilesAreLeftByteForByte) {
  guideway::test::TempDir dir;
  const std::string newer = dir.file("newer.sqlite");
  { Store s(newer); }
  sqlite3* db = nullptr;
  ASSERT_EQ(sqlite3_open(newer.c_str(), &db), SQLITE_OK);
  ASSERT_EQ(sqlite3_exec(db, "PRAGMA journal_mode=DELETE; PRAGMA user_version=9", nullptr, nullptr, nullptr),
            SQLITE_OK);
  sqlite3_close(db);
  const std::string other = dir.file("other.sqlite");
  ASSERT_EQ(sqlite3_open(other.c_str(), &db), SQLITE_OK);
  ASSERT_EQ(sqlite3_exec(db, "CREATE TABLE t(x); INSERT INTO t VALUES(1)", nullptr, nullptr, nullptr), SQLITE_OK);
  sqlite3_close(db);
  for (const auto& path : {newer, other}) {
    std::filesystem::remove(path + "-wal");
    std::filesystem::remove(path + "-shm");
    const std::string before = bytes_of(path);
    EXPECT_THROW(Store{path}, std::runtime_error);
    EXPECT_EQ(bytes_of(path), before) << path << " was altered";  // not even switched to WAL
    EXPECT_FALSE(std::filesystem::exists(path + "-wal")) << path;
  }
}

TEST(FleetIngest, ABatchIsStoredWholeOrNotAtAll) {
  guideway::test::TempDir dir;
  const std::string path = dir.file("fleet.sqlite");
  Store s(path);
  s.set_busy_timeout_ms(200);
  std::vector<std::string> payloads;
  for (int i = 0; i < 5; ++i) payloads.push_back(R"({"class":"EVENT","n":)" + std::to_string(i) + "}");
  std::vector<IngestInput> batch;
  const std::string t = topic("m", "event");
  for (const auto& p : payloads) batch.push_back({t, p, "", "2026-11-26T12:00:00Z"});
  batch.push_back({t, "{broken", "", "2026-11-26T12:00:00Z"});  // refused inside the batch: the others stay
  // Another connection holds the write lock (a long reader-writer, a backup): the batch fails whole.
  sqlite3* locker = nullptr;
  ASSERT_EQ(sqlite3_open(path.c_str(), &locker), SQLITE_OK);
  ASSERT_EQ(sqlite3_exec(locker, "BEGIN EXCLUSIVE", nullptr, nullptr, nullptr), SQLITE_OK);
  EXPECT_THROW(s.ingest_batch(prefix, batch), std::runtime_error);
  ASSERT_EQ(sqlite3_exec(locker, "COMMIT", nullptr, nullptr, nullptr), SQLITE_OK);
  sqlite3_close(locker);
  EXPECT_TRUE(s.events("m").empty());
  EXPECT_EQ(s.refused_count(), 0);
  const auto results = s.ingest_batch(prefix, batch);
  ASSERT_EQ(results.size(), 6u);
  for (int i = 0; i < 5; ++i) EXPECT_EQ(results[static_cast<std::size_t>(i)].outcome, IngestResult::stored);
  EXPECT_EQ(results[5].outcome, IngestResult::refused);
  EXPECT_EQ(s.events("m").size(), 5u);
  EXPECT_EQ(s.refused_count(), 1);
  // The same batch again (a redelivery after a crash between commit and acknowledgement): nothing twice.
  const auto again = s.ingest_batch(prefix, batch);
  EXPECT_EQ(again[0].outcome, IngestResult::duplicate);
  EXPECT_EQ(s.events("m").size(), 5u);
}

TEST(FleetIngest, OversizedAndDeeplyNestedPayloadsAreRefused) {
  guideway::test::TempDir dir;
  Store s(dir.file("fleet.sqlite"));
  s.set_max_payload_bytes(1000);
  const std::string big = R"({"class":"EVENT","text":")" + std::string(2000, 'x') + "\"}";
  const auto r = s.ingest(prefix, topic("m", "event"), big, "", "2026-11-26T12:00:00Z");
  EXPECT_EQ(r.outcome, IngestResult::refused);
  EXPECT_NE(r.reason.find("over the fleet's maximum of 1000"), std::string::npos) << r.reason;
  const std::string deep = std::string(500, '[') + std::string(500, ']');
  EXPECT_NE(s.ingest(prefix, topic("m", "event"), deep, "", "2026-11-26T12:00:00Z").reason.find("nested deeper"),
            std::string::npos);
  // Brackets inside strings are text, not nesting.
  const std::string text = R"({"class":"EVENT","reason":")" + std::string(100, '[') + "\"}";
  EXPECT_EQ(put(s, topic("m", "event"), text, ""), IngestResult::stored);
}

// Property: whatever sequence of payloads arrives (the documented shapes with fields of every type,
// and shapes that are wrong), every ingest ends stored, duplicate, ignored or refused, and status,
// history and the report still answer after each.
TEST(FleetIngest, RandomPayloadsNeverStopTheView) {
  guideway::test::TempDir dir;
  Store s(dir.file("fleet.sqlite"));
  std::mt19937 rng(20261127);
  const auto pick = [&](std::size_t n) { return std::uniform_int_distribution<std::size_t>(0, n - 1)(rng); };
  std::function<nlohmann::json(int)> any_value = [&](int depth) -> nlohmann::json {
    switch (pick(depth > 2 ? 6 : 8)) {
      case 0:
        return nullptr;
      case 1:
        return pick(2) == 1;
      case 2:
        return static_cast<double>(pick(2000)) - 1000.5;
      case 3:
        return std::vector<std::string>{"", "~x", "xy", "zx", "xx", "~1", "/", "\x1b[2J", "1e400"}[pick(9)];
      case 4:
        return std::numeric_limits<double>::max();
      case 5:
        return static_cast<int>(pick(10));
      case 6: {
        nlohmann::json a = nlohmann::json::array();
        for (std::size_t i = pick(3); i > 0; --i) a.push_back(any_value(depth + 1));
        return a;
      }
      default: {
        nlohmann::json o = nlohmann::json::object();
        for (const char* k : {"effect", "contribution_um", "value", "u", "plane"})
          if (pick(2)) o[k] = any_value(depth + 1);
        return o;
      }
    }
  };
  const auto golden_params = golden_json("dbb.params.json");
  // The golden EXPLAIN's findings without its 89 kB of residuals: the readers parse every stored row.
  nlohmann::json golden_explain = {{"class", "EXPLAIN"}, {"findings", nlohmann::json::array()}, {"unexplained", false}};
  const auto full_explain = golden_json("dbb.explain.json");
  for (const auto& f : full_explain["findings"])
    golden_explain["findings"].push_back({{"effect", f["effect"]}, {"contribution_um", f["contribution_um"]}});
  const char* leaves[] = {"params/dbb", "explain/dbb", "params/runout", "explain/profile",
                          "status",     "event",       "devices"};
  int stored = 0, refused = 0;
  for (int i = 0; i < 500; ++i) {
    const std::string leaf = leaves[pick(7)];
    nlohmann::json j;
    switch (pick(4)) {
      case 0:
        j = any_value(0);
        break;  // any shape at all
      case 1:
        j = leaf.starts_with("explain") ? golden_explain : golden_params;
        break;
      default:  // a documented shape with one field of any type
        j = leaf.starts_with("explain") ? golden_explain : golden_params;
        for (const char* pointer : {"/plane", "/findings", "/findings/0/effect", "/findings/0/contribution_um",
                                    "/diagnostics/circular_deviation_um/value", "/lai3/backlash_x_um/u", "/session",
                                    "/state", "/since", "/unexplained"})
          if (pick(6) == 0) {
            try {
              j[nlohmann::json::json_pointer(pointer)] = any_value(1);
            } catch (const nlohmann::json::exception&) {  // "/findings/0" after findings became an object
            }
          }
        j["session"] = "s" + std::to_string(i);
    }
    const std::string machine = "m" + std::to_string(pick(3));
    const auto r =
        s.ingest(prefix,
                 topic(machine, leaf.substr(0, leaf.find('/')),
                       leaf.find('/') == std::string::npos ? "" : leaf.substr(leaf.find('/') + 1)),
                 j.dump(), pick(5) == 0 ? "0999-01-01T00:00:00Z" : "2026-11-26T10:00:00Z", "2026-11-26T12:00:00Z");
    stored += r.outcome == IngestResult::stored;
    refused += r.outcome == IngestResult::refused;
    if (i % 50 == 0) {
      ASSERT_NO_THROW(read_everything(s, i % 250 == 0)) << "after payload " << i << ": " << j.dump();
    }
  }
  ASSERT_NO_THROW(read_everything(s));
  EXPECT_GT(stored, 50);  // the generator makes both kinds
  EXPECT_GT(refused, 50);
  EXPECT_EQ(s.refused_count(), refused);
}

TEST(FleetView, ControlCharactersFromTheBrokerNeverReachTheTerminal) {
  guideway::test::TempDir dir;
  Store s(dir.file("fleet.sqlite"));
  const std::string esc = "\x1b[2J\x1b]0;owned\x07";
  put(s, topic("m", "status"), nlohmann::json{{"state", "offline"}, {"reason", "lost " + esc}}.dump(), "");
  auto p = golden_json("dbb.params.json");
  p["session"] = "s" + esc;
  put(s, topic("m", "params", "dbb"), p.dump(), "2026-11-26T10:00:00Z");
  put(s, topic("m", "explain", "dbb"), nlohmann::json{{"findings", {{{"effect", "spike" + esc}}}}}.dump(), "");
  const std::string status = status_text(fleet_status(s, 1795694400.0));
  const std::string history = history_text("m", history_of(s.results("m")));
  for (const auto& text : {status, history}) {
    EXPECT_EQ(text.find('\x1b'), std::string::npos) << text;
    EXPECT_EQ(text.find('\x07'), std::string::npos) << text;
    EXPECT_NE(text.find("\\x1b[2J"), std::string::npos) << text;
  }
  EXPECT_NE(status.find("spike\\x1b"), std::string::npos) << status;
  // The HTML report too (issue 46 item 10: it copied the raw bytes): visible escapes, like the text views.
  const std::string html = render_fleet_report(s, FleetReportOptions{});
  EXPECT_EQ(html.find('\x1b'), std::string::npos);
  EXPECT_EQ(html.find('\x07'), std::string::npos);
  EXPECT_NE(html.find("spike\\x1b[2J\\x1b]0;owned\\x07"), std::string::npos);
}

TEST(FleetView, AgesInTheFutureHugeValuesAndOneAnchorPerMachine) {
  EXPECT_EQ(format_age_ago(-5.0), "in the future");  // was "in the future ago"
  EXPECT_EQ(format_age_ago(30.0), "30 s ago");
  // Values of 1e63 and over were cut at 64 bytes.
  HistoryEntry e{"dbb", "PARAMS", "2026-11-26T10:00:00.000Z", "", "s", {}, {}, true, {}, {}, {}};
  e.figures.push_back({Headline{"g", "G", "µm", 1e70, 0.5}, std::nullopt, false});
  const std::string text = history_text("m", {e});
  // Every digit down to u's (0.50) is there, as the mantissa of the power of ten value and u share.
  const auto at = text.find("G: (1.") + 6;
  EXPECT_EQ(text.find(' ', at) - at, 72u) << text;
  EXPECT_NE(text.find("050)e70 µm"), std::string::npos) << text;

  guideway::test::TempDir dir;
  Store s(dir.file("fleet.sqlite"));
  for (const std::string m : {"mill.1", "mill-1", "mill 1", "mill_1"})
    put(s, topic(m, "params", "dbb"), golden("dbb.params.json"), "2026-11-26T10:00:00Z");
  const std::string html = render_fleet_report(s, FleetReportOptions{});
  std::set<std::string> ids;
  for (auto id = html.find("id=\"machine-"); id != std::string::npos; id = html.find("id=\"machine-", id + 1))
    ids.insert(html.substr(id + 4, html.find('"', id + 4) - id - 4));
  EXPECT_EQ(ids.size(), 4u) << html.substr(0, 200);
  EXPECT_TRUE(ids.count("machine-mill-2e1") && ids.count("machine-mill-2d1") && ids.count("machine-mill-201") &&
              ids.count("machine-mill_1"));
}
