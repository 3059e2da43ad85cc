// Instrument identity and calibration (issue 30, part 4; docs/configuration.md "Instrument identity and
// calibration"): the [[device]] keys and their checks, the calendar dates they use, the recording header
// and the PARAMS header carrying them (written, read back), the report's table, the fleet's history, and
// dbb-can's use of the bar's serial and calibrated length.
#include <gtest/gtest.h>

#include <fstream>

#include "core/instrument.hpp"
#include "daemon/config.hpp"
#include "drivers/dbb/dbb_driver.hpp"
#include "fleet/history.hpp"
#include "formats/raw_recording.hpp"
#include "report/sections.hpp"
#include "results/result_header.hpp"
#include "test_support.hpp"

using namespace guideway;

namespace {

std::string config_error(const std::string& text) {
  try {
    (void)daemon::parse_config(text, "t.toml");
  } catch (const ConfigError& e) {
    return e.what();
  }
  return "";
}

// A dbb device table (no driver is created: the daemon's own checks) with `extra` lines.
std::string dbb_device(const std::string& extra) {
  return "[[device]]\nname = \"dbb\"\ndriver = \"dbb-can\"\n" + extra;
}

CalendarDate date(const char* iso) { return parse_iso_date(iso).value(); }

Instrument bar_instrument() {
  Instrument in;
  in.serial = "1001";
  in.calibration_certificate = "C-2023-117";
  in.calibrated_on = date("2023-01-10");
  in.calibration_due = date("2024-01-10");
  in.calibrated_length_mm = 100.0;
  in.calibrated_length_u_um = 0.5;
  return in;
}

// The header of a DBB session on the bar, judged on 2025-02-25 (past its due date).
results::ResultHeader bar_session_header() {
  results::ResultHeader h;
  h.session = "dbb-dbb-1";
  h.kind = "dbb";
  h.device = "dbb";
  h.instrument = bar_instrument();
  h.instrument_checked_on = date("2025-02-25");
  return h;
}

}  // namespace

TEST(CalendarDates, AreIsoCalendarDatesThatExist) {
  EXPECT_EQ(parse_iso_date("2024-02-29"), (CalendarDate{2024, 2, 29}));
  for (const char* bad : {"2025-02-29", "2025-13-01", "2025-00-10", "2025-3-01", "2025-03-01T00:00", "25-03-01",
                          "2025/03/01", "", "2100-02-29"})
    EXPECT_FALSE(parse_iso_date(bad)) << bad;
  EXPECT_EQ(to_iso({2025, 3, 4}), "2025-03-04");
  EXPECT_EQ(days_between(date("2024-01-10"), date("2025-02-25")), 412);
  EXPECT_EQ(days_between(date("2025-02-25"), date("2024-01-10")), -412);
  EXPECT_EQ(utc_date(0.0), (CalendarDate{1970, 1, 1}));
  EXPECT_EQ(utc_date(1'700'000'000.0), (CalendarDate{2023, 11, 14}));
}

TEST(InstrumentCalibration, RunsOutTheDayAfterItIsDueAndSaysSoNamingTheInstrument) {
  const Instrument in = bar_instrument();
  EXPECT_FALSE(calibration_expired(in, date("2024-01-10")));
  EXPECT_TRUE(calibration_expired(in, date("2024-01-11")));
  EXPECT_EQ(calibration_warning("dbb", in, date("2024-01-10")), "");
  EXPECT_EQ(calibration_warning("dbb", in, date("2025-02-25")),
            "device dbb (serial 1001, certificate C-2023-117): calibration was due 2024-01-10, 412 days before "
            "2025-02-25: recalibrate the instrument or update calibration_due");
  Instrument no_due;
  no_due.serial = "7";
  EXPECT_FALSE(calibration_expired(no_due, date("2999-01-01")));
  EXPECT_TRUE(Instrument{}.empty());
  EXPECT_FALSE(no_due.empty());
}

TEST(InstrumentConfig, ReadsEveryKeyAsTomlDatesOrStrings) {
  const auto c = daemon::parse_config("[daemon]\nrefuse_uncalibrated = true\n" +
                                          dbb_device("serial = \"1001\"\ncalibration_certificate = \"C-2023-117\"\n"
                                                     "calibrated_on = 2023-01-10\ncalibration_due = \"2024-01-10\"\n"
                                                     "calibrated_length_mm = 100\ncalibrated_length_u_um = 0.5\n"),
                                      "t.toml");
  EXPECT_TRUE(c.refuse_uncalibrated);
  ASSERT_EQ(c.devices.size(), 1u);
  EXPECT_EQ(c.devices[0].instrument, bar_instrument());
  EXPECT_EQ(daemon::calibration_warnings(c, date("2024-01-10")), std::vector<std::string>{});
  const auto w = daemon::calibration_warnings(c, date("2025-02-25"));
  ASSERT_EQ(w.size(), 1u);
  EXPECT_EQ(w[0].rfind("device dbb (serial 1001, certificate C-2023-117): calibration was due 2024-01-10", 0), 0u);
  // A device that states nothing has no instrument; refuse_uncalibrated is off by default.
  const auto plain = daemon::parse_config(dbb_device(""), "t.toml");
  EXPECT_TRUE(plain.devices[0].instrument.empty());
  EXPECT_FALSE(plain.refuse_uncalibrated);
}

TEST(InstrumentConfig, BadValuesAreErrorsNamingFileLineAndKey) {
  EXPECT_EQ(config_error(dbb_device("calibrated_on = \"2025-02-30\"\n")),
            "t.toml:4: device[0].calibrated_on: expected a date YYYY-MM-DD (a TOML date such as 2025-03-14, or the "
            "string \"2025-03-14\"), got \"2025-02-30\"");
  EXPECT_EQ(config_error(dbb_device("calibration_due = \"14.03.2025\"\n"))
                .rfind("t.toml:4: device[0].calibration_due: "
                       "expected a date YYYY-MM-DD",
                       0),
            0u);
  EXPECT_EQ(config_error(dbb_device("calibration_due = 20250314\n")).find("got an integer") != std::string::npos, true);
  EXPECT_EQ(config_error(dbb_device("calibrated_on = 2025-03-14\ncalibration_due = 2025-03-13\n")),
            "t.toml:5: device[0].calibration_due: 2025-03-13 is before calibrated_on (2025-03-14): the due date comes "
            "after the calibration");
  EXPECT_EQ(config_error(dbb_device("calibrated_length_mm = 100\ncalibrated_length_u_um = -0.5\n")),
            "t.toml:5: device[0].calibrated_length_u_um: a standard uncertainty is zero or positive, got -0.5 (the "
            "certificate's u, in um)");
  EXPECT_EQ(config_error(dbb_device("calibrated_length_mm = -100\n")),
            "t.toml:4: device[0].calibrated_length_mm: must be a positive length, got -100");
  EXPECT_EQ(config_error(dbb_device("calibrated_length_u_um = 0.5\n")),
            "t.toml:4: device[0].calibrated_length_u_um: needs calibrated_length_mm (the length it is the uncertainty "
            "of)");
  EXPECT_EQ(config_error("[[device]]\nname = \"ac\"\ndriver = \"autocollimator-serial\"\ncalibrated_length_mm = 100\n"),
            "t.toml:4: device[0].calibrated_length_mm: applies to a ballbar (driver \"dbb-can\"), not to driver "
            "\"autocollimator-serial\"");
  EXPECT_NE(config_error("[daemon]\nrefuse_uncalibrated = \"yes\"\n").find("daemon.refuse_uncalibrated: expected true"),
            std::string::npos);
}

// Issue 46 items 5 and 6: what --check-config passed and the daemon then streamed or refused every start on.
TEST(InstrumentConfig, ImplausibleCalibrationsAreErrorsAtTheirLine) {
  EXPECT_EQ(config_error(dbb_device("calibrated_length_mm = 1e308\n")),
            "t.toml:4: device[0].calibrated_length_mm: 1e+308 mm is over 3000 mm, a ballbar's length (with extensions)");
  EXPECT_EQ(config_error(dbb_device("calibrated_length_mm = 100\ncalibrated_length_u_um = 1e300\n")),
            "t.toml:5: device[0].calibrated_length_u_um: 1e+300 um is over 1000 um: a bar known no better than a "
            "millimetre is not calibrated");
  EXPECT_EQ(config_error(dbb_device("calibrated_on = 9999-12-31\n")).rfind(
                "t.toml:4: device[0].calibrated_on: 9999-12-31 is after today (", 0),
            0u);
  EXPECT_EQ(config_error(dbb_device("calibrated_on = 2023-01-10\ncalibration_due = 9999-12-31\n")),
            "t.toml:5: device[0].calibration_due: 9999-12-31 is more than 10 years after calibrated_on (2023-01-10): "
            "no certificate runs that long");
  EXPECT_EQ(config_error(dbb_device("serial = \"\"\n")),
            "t.toml:4: device[0].serial: is empty: state it as on the instrument's plate or certificate, or leave the "
            "key out");
  EXPECT_EQ(config_error(dbb_device("calibration_certificate = \" \"\n")).rfind(
                "t.toml:4: device[0].calibration_certificate: is empty", 0),
            0u);
  EXPECT_EQ(config_error("[daemon]\nrefuse_uncalibrated = true\n" + dbb_device("serial = \"1001\"\n")),
            "t.toml:2: daemon.refuse_uncalibrated: every session would be refused on device(s) dbb: no calibration_due "
            "is stated (state calibrated_on and calibration_due in their [[device]] tables, or set "
            "refuse_uncalibrated = false)");
}

TEST(InstrumentRecording, TheHeaderKeysAreWrittenAndReadBack) {
  test::TempDir dir;
  formats::RawRecordingHeader h;
  h.device = "dbb";
  h.driver = "dbb-can";
  h.started_utc = "2025-02-25T10:00:00.000Z";
  h.metadata = {{"kind", "dbb"}, {"session", "dbb-dbb-1"}};
  h.metadata.merge(formats::instrument_metadata(bar_instrument()));
  h.channels = {{"bar_length", "m"}};
  const std::string header = formats::format_raw_header(h);
  EXPECT_NE(header.find("# instrument_calibrated_length_u_um = 0.5\n# instrument_calibrated_on = 2023-01-10\n"
                        "# instrument_calibration_certificate = C-2023-117\n# instrument_calibration_due = 2024-01-10\n"
                        "# instrument_serial = 1001\n"),
            std::string::npos)
      << header;
  const std::string path = dir.file("r.csv");
  { std::ofstream(path) << header; }
  const formats::RawRecording r = formats::read_raw_recording(path);
  EXPECT_EQ(r.instrument, bar_instrument());
  // A recording without the keys (every recording before them) reads as before: no instrument.
  h.metadata = {{"kind", "dbb"}, {"session", "dbb-dbb-1"}};
  { std::ofstream(path) << formats::format_raw_header(h); }
  EXPECT_TRUE(formats::read_raw_recording(path).instrument.empty());
  // Only the parts stated are written.
  Instrument serial_only;
  serial_only.serial = "QC20-W 1234";
  EXPECT_EQ(formats::instrument_metadata(serial_only),
            (std::map<std::string, std::string>{{"instrument_serial", "QC20-W 1234"}}));
  // A malformed value names the file and key.
  h.metadata["instrument_calibration_due"] = "2024-02-30";
  { std::ofstream(path) << formats::format_raw_header(h); }
  try {
    (void)formats::read_raw_recording(path);
    FAIL() << "a date that does not exist was read";
  } catch (const std::runtime_error& e) {
    EXPECT_EQ(std::string(e.what()), path + ": instrument_calibration_due: not a date YYYY-MM-DD: '2024-02-30'");
  }
}

TEST(InstrumentResultHeader, IsWrittenJudgedOnTheSessionsDateAndReadBack) {
  results::ResultHeader h = bar_session_header();
  const nlohmann::json j = results::with_header({{"model", "m"}}, h);
  EXPECT_EQ(j["instrument"].dump(),
            R"({"calibrated_length_mm":100.0,"calibrated_length_u_um":0.5,"calibrated_on":"2023-01-10",)"
            R"("calibration_certificate":"C-2023-117","calibration_due":"2024-01-10","calibration_expired":true,)"
            R"("checked_on":"2025-02-25","serial":"1001","warning":"device dbb (serial 1001, certificate C-2023-117): )"
            R"(calibration was due 2024-01-10, 412 days before 2025-02-25: recalibrate the instrument or update )"
            R"(calibration_due"})");
  const results::ResultHeader back = results::read_header(j);
  EXPECT_EQ(back.instrument, h.instrument);
  EXPECT_EQ(back.instrument_checked_on, h.instrument_checked_on);
  // In date: no warning; a header without an instrument has none.
  h.instrument_checked_on = date("2023-06-01");
  const nlohmann::json valid = results::with_header({}, h);
  EXPECT_FALSE(valid["instrument"]["calibration_expired"].get<bool>());
  EXPECT_FALSE(valid["instrument"].contains("warning"));
  h.instrument = {};
  EXPECT_FALSE(results::with_header({}, h).contains("instrument"));
  EXPECT_TRUE(results::read_header(results::with_header({}, h)).instrument.empty());
}

TEST(InstrumentReport, TheTableShowsEachInstrumentAndWarnsOfAnExpiredOne) {
  Instrument ac;
  ac.serial = "TA80-<5>";
  ac.calibration_due = date("2030-01-01");
  const std::string html =
      report::instruments_section({{"dbb", bar_instrument()}, {"autocollimator", ac}}, date("2025-02-25"), "i-1");
  EXPECT_NE(html.find("<h2>Instruments</h2>"), std::string::npos) << html;
  EXPECT_NE(html.find("<td class=\"l\">1001</td><td class=\"l\">C-2023-117</td><td>2023-01-10</td><td>2024-01-10</td>"
                      "<td>100.0000 mm (u = 0.5 &micro;m)</td><td class=\"l\"><strong>EXPIRED</strong></td>"),
            std::string::npos)
      << html;
  EXPECT_NE(html.find("TA80-&lt;5&gt;"), std::string::npos) << "text is escaped";
  EXPECT_NE(html.find("<td class=\"l\">valid</td>"), std::string::npos) << html;
  EXPECT_NE(
      html.find("<p class=\"note\">Warning: device dbb (serial 1001, certificate C-2023-117): calibration was due "
                "2024-01-10, 412 days before 2025-02-25"),
      std::string::npos)
      << html;
  EXPECT_EQ(html.find("device autocollimator ("), std::string::npos) << "no warning for one in date";
}

TEST(InstrumentFleetHistory, AResultsInstrumentIsShownWithItsDueDate) {
  results::ResultHeader h = bar_session_header();
  const nlohmann::json params = results::with_header({{"class", "PARAMS"}, {"model", "lai3+ballbar"}}, h);
  fleet::ResultRow row;
  row.kind = "dbb";
  row.message_class = "PARAMS";
  row.produced_utc = "2025-02-25T10:00:00.000Z";
  row.session = "dbb-dbb-1";
  row.payload = params.dump();
  const auto entries = fleet::history_of({row});
  ASSERT_EQ(entries.size(), 1u);
  EXPECT_EQ(entries[0].instrument, bar_instrument());
  const std::string text = fleet::history_text("mill-1", entries);
  EXPECT_NE(text.find("    instrument: serial 1001, certificate C-2023-117, due 2024-01-10 (EXPIRED at the session, "
                      "2025-02-25)\n"),
            std::string::npos)
      << text;
  const nlohmann::json j = fleet::history_json("mill-1", entries);
  EXPECT_EQ(j["results"][0]["instrument"]["serial"], "1001");
  EXPECT_EQ(j["results"][0]["instrument"]["calibration_due"], "2024-01-10");
  EXPECT_TRUE(j["results"][0]["instrument"]["calibration_expired"].get<bool>());
}

// dbb-can: the bar is its length encoder; its reading at zero_count is the calibrated length, and a
// numeric serial is what that node must report.
TEST(InstrumentDbbCan, TheBarTakesItsSerialAndCalibratedLengthFromTheDeviceTable) {
  const auto settings = [](const std::string& extra, const std::string& bar_extra) {
    const toml::table t = parse_toml("bus = \"unix:/tmp/x.sock\"\n" + extra +
                                         "[[encoder]]\nchannel = \"x\"\nnode_id = 2\nresolution_nm = 100\n"
                                         "[[encoder]]\nchannel = \"bar_length\"\nnode_id = 1\nresolution_nm = 100\n" +
                                         bar_extra,
                                     "t.toml");
    return drivers::dbb::parse_dbb_settings(TableReader(t, "t.toml", "device[0]"));
  };
  const auto s = settings("serial = \"0x3E9\"\ncalibrated_length_mm = 100.0012\n", "");
  EXPECT_DOUBLE_EQ(s.encoders[1].offset_m, 0.1000012) << "the bar's offset is its calibrated length";
  EXPECT_DOUBLE_EQ(s.encoders[0].offset_m, 0.0);
  EXPECT_EQ(s.nodes[1].instrument_serial, 1001u) << "compared on the bar's node";
  EXPECT_FALSE(s.nodes[0].instrument_serial);
  EXPECT_FALSE(settings("serial = \"QC20-W 1001\"\n", "").nodes[1].instrument_serial) << "not a number: not compared";
  EXPECT_DOUBLE_EQ(settings("calibrated_length_mm = 100.0012\n", "offset_mm = 100.0012\n").encoders[1].offset_m,
                   0.1000012);
  try {
    (void)settings("calibrated_length_mm = 100.0012\n", "offset_mm = 100.0\n");
    FAIL() << "an offset that is not the calibrated length was taken";
  } catch (const ConfigError& e) {
    EXPECT_EQ(std::string(e.what()),
              "t.toml:11: device[0].encoder[1].offset_mm: 100 mm differs from the bar's calibrated_length_mm = "
              "100.0012 mm: the bar reads its calibrated length at zero_count (leave offset_mm out to take it from "
              "calibrated_length_mm)");
  }
}
