// fleet/: the store on real SQLite files (golden PARAMS and EXPLAIN of every session kind under two
// machines, duplicates, wills, produced-time order, schema versions), the headline figures read from the
// golden files, the moved flag (k = 2) and the fleet status built from the store.
#include <sqlite3.h>
#include <sys/stat.h>

#include <atomic>
#include <cmath>
#include <cstdlib>
#include <fstream>
#include <sstream>
#include <thread>

#include <gtest/gtest.h>
#include <nlohmann/json.hpp>

#include "fleet/fleet_status.hpp"
#include "fleet/headlines.hpp"
#include "fleet/history.hpp"
#include "fleet/store.hpp"
#include "test_support.hpp"

using namespace guideway::fleet;

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
  EXPECT_EQ(p[0].session, "runout-micrometer-20261121T095158Z");
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
  EXPECT_EQ(r.outcome, IngestResult::ignored);
  EXPECT_NE(r.reason.find("not our topic tree"), std::string::npos);
  EXPECT_NE(
      s.ingest(prefix, topic("x", "params", "dbb"), "{not json", "", "2026-11-26T11:00:00Z").reason.find("not JSON"),
      std::string::npos);
  EXPECT_EQ(put(s, topic("x", "explain", "dbb"), golden("dbb.params.json"), ""), IngestResult::ignored);  // a PARAMS
  EXPECT_EQ(put(s, topic("x", "status"), R"({"state":"online","machine":"y"})", ""), IngestResult::ignored);
  EXPECT_EQ(s.machines().size(), 2u);  // an ignored message leaves no machine behind
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
    EXPECT_NE(std::string(e.what()).find("schema is version 7, newer than this guideway knows (1)"), std::string::npos)
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
  const auto dbb = headlines("dbb", golden_json("dbb.params.json"));
  ASSERT_EQ(dbb.size(), 3u);  // G, and backlash from lai3: the golden run gives no ballbar diagnostics
  EXPECT_EQ(dbb[0].name, "circular_deviation_um");
  EXPECT_DOUBLE_EQ(dbb[0].value, 17.417894088049465);
  EXPECT_FALSE(dbb[0].u);
  EXPECT_DOUBLE_EQ(find(dbb, "backlash_x_um").value, 0.9956473599246491);
  EXPECT_DOUBLE_EQ(*find(dbb, "backlash_x_um").u, 0.008036227194117824);
  EXPECT_DOUBLE_EQ(find(dbb, "backlash_y_um").value, 1.98665042712081);

  const auto runout = headlines("runout", golden_json("runout.params.json"));
  EXPECT_DOUBLE_EQ(find(runout, "squareness_urad").value, 2.783728082308546);
  EXPECT_DOUBLE_EQ(*find(runout, "squareness_urad").u, 0.0017572725568859374);
  EXPECT_DOUBLE_EQ(find(runout, "runout_um").value, 0.2837280823085464);

  const auto st = headlines("straightness", golden_json("straightness.params.json"));
  ASSERT_EQ(st.size(), 2u);
  EXPECT_DOUBLE_EQ(find(st, "horizontal_straightness_um").value, 0.02703768606187836);
  EXPECT_DOUBLE_EQ(*find(st, "horizontal_straightness_um").u, 0.23125132280376762);
  EXPECT_DOUBLE_EQ(find(st, "vertical_straightness_um").value, 0.07891808072092471);
  EXPECT_DOUBLE_EQ(*find(st, "vertical_straightness_um").u, 0.19924894888796588);

  const auto pr = headlines("profile", golden_json("profile.params.json"));
  EXPECT_DOUBLE_EQ(find(pr, "straightness_lsq_um").value, 0.2055772949384913);
  EXPECT_DOUBLE_EQ(*find(pr, "straightness_lsq_um").u, 0.0290585618977036);
  EXPECT_DOUBLE_EQ(find(pr, "form_straightness_um").value, 0.05332820189032894);
  EXPECT_TRUE(headlines("flatness", golden_json("profile.params.json")).empty());
}

TEST(FleetHeadlines, DbbDiagnosticsComeFirstAndNameThePlaneAxes) {
  auto p = golden_json("dbb.params.json");
  p["plane"] = "zx";
  p["diagnostics"]["squareness_urad"] = {{"value", 12.5}, {"u", 0.4}};
  p["diagnostics"]["backlash_z_um"] = {{"value", 3.25}, {"u", 0.05}};
  p["diagnostics"]["scale_x_ppm"] = {{"value", -8.0}, {"u", 0.3}};
  p["lai3"]["backlash_z_um"] = p["lai3"]["backlash_x_um"];
  const auto h = headlines("dbb", p);
  EXPECT_DOUBLE_EQ(find(h, "squareness_urad").value, 12.5);
  EXPECT_DOUBLE_EQ(find(h, "backlash_z_um").value, 3.25);  // diagnostics before lai3
  EXPECT_EQ(find(h, "backlash_z_um").label, "backlash z");
  EXPECT_DOUBLE_EQ(find(h, "scale_x_ppm").value, -8.0);
  EXPECT_THROW(find(h, "scale_z_ppm"), std::runtime_error);  // absent: not listed
}

TEST(FleetHeadlines, ExplainFindings) {
  const auto s = explain_summary(golden_json("dbb.explain.json"));
  ASSERT_EQ(s.findings.size(), 2u);
  EXPECT_EQ(s.findings[0].effect, "backlash");
  EXPECT_DOUBLE_EQ(s.findings[0].contribution_um, 1.9898527045693912);
  EXPECT_EQ(s.findings[1].effect, "vibration");
  EXPECT_FALSE(s.unexplained);
  EXPECT_EQ(to_text(s), "backlash 1.99 µm, vibration 0.0246 µm");
  const auto r = explain_summary(golden_json("runout.explain.json"));
  EXPECT_TRUE(r.unexplained);
  EXPECT_TRUE(r.findings.empty());
  EXPECT_EQ(to_text(r), "not analysed");
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
  EXPECT_NE(text.find("backlash x/µm"), std::string::npos) << text;
  EXPECT_NE(text.find("36.0 h ago"), std::string::npos) << text;
  EXPECT_NE(text.find("k = 2"), std::string::npos) << text;
  const auto j = status_json(status);
  EXPECT_EQ(j["machines"][0]["latest"]["dbb"]["session"], "s3");
  EXPECT_EQ(j["machines"][0]["explain"]["dbb"]["findings"][0]["effect"], "backlash");
}
