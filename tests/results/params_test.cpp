// PARAMS as a type (results/params.hpp): the golden PARAMS of every session kind read and written again byte
// for byte, their figures named by their catalogue entries, every kind's record typed (results/dbb_record.hpp,
// kind_records.hpp, traverse_record.hpp), and what params_from_json refuses, naming the field.
#include <cmath>
#include <cstdint>
#include <fstream>
#include <iterator>
#include <limits>
#include <optional>
#include <random>
#include <sstream>
#include <string>
#include <vector>

#include <gtest/gtest.h>
#include <nlohmann/json.hpp>

#include "json_nodes.hpp"
#include "results/params.hpp"
#include "results/result_header.hpp"

using namespace guideway;

namespace {

nlohmann::json golden(const std::string& name) {
  std::ifstream in(std::string(GUIDEWAY_SOURCE_DIR) + "/tests/golden/" + name);
  std::stringstream s;
  s << in.rdbuf();
  return nlohmann::json::parse(s.str());
}

// A message without its header: what to_json writes.
nlohmann::json body_of(nlohmann::json message) {
  for (auto it = message.begin(); it != message.end();)
    it = results::is_header_key(it.key()) ? message.erase(it) : std::next(it);
  return message;
}

std::string refusal(const std::string& text) {
  try {
    (void)results::params_from_json(nlohmann::json::parse(text));
  } catch (const results::ParamsFormatError& e) {
    return e.what();
  }
  return "";
}

}  // namespace

TEST(Params, TheGoldenResultsOfEveryKindAreWrittenAgainByteForByte) {
  for (const char* kind : {"dbb", "straightness", "runout", "profile"}) {
    SCOPED_TRACE(kind);
    const nlohmann::json message = golden(std::string(kind) + ".params.json");
    EXPECT_EQ(results::to_json(results::params_from_json(message)).dump(), body_of(message).dump());
  }
}

TEST(Params, FiguresAreTypedAndNamedByTheirCatalogueEntries) {
  const results::Params dbb = results::params_from_json(golden("dbb.params.json"));
  EXPECT_EQ(dbb.model, "lai3+ballbar");
  EXPECT_EQ(dbb.plane, "xy");
  EXPECT_EQ(dbb.test, "lai");
  const results::Figure* backlash = dbb.find("lai3", "backlash_x_um");
  ASSERT_NE(backlash, nullptr);
  EXPECT_EQ(backlash->entry, &results::backlash);  // its place in lai3: one entry per quantity
  EXPECT_DOUBLE_EQ(backlash->value, 0.9956119370815951);
  ASSERT_TRUE(backlash->u);
  EXPECT_DOUBLE_EQ(*backlash->u, 0.008007586351895687);
  const results::Figure* g = dbb.find("diagnostics", "circular_deviation_um");
  ASSERT_NE(g, nullptr);
  EXPECT_EQ(g->entry, &results::circular_deviation);
  EXPECT_FALSE(g->u);  // a range as measured: no uncertainty of its own
  EXPECT_TRUE(dbb.dbb);  // the DBB record, typed: DbbRecordIsTyped
  EXPECT_FALSE(dbb.record.contains("runs"));
  EXPECT_FALSE(dbb.record.contains("lai3"));
  EXPECT_FALSE(dbb.record.contains("session"));  // the header is not the body's

  const results::Params runout = results::params_from_json(golden("runout.params.json"));
  EXPECT_EQ(runout.find("squareness", "runout_um")->entry, &results::runout);
  EXPECT_EQ(runout.find("squareness", "squareness_urad")->entry, &results::runout_squareness);
  EXPECT_EQ(runout.find("squareness", "once_per_rev_amplitude_um")->entry, nullptr);
  EXPECT_EQ(runout.find("error_motion", "total_error_motion_um")->entry, &results::total_error_motion);
  EXPECT_FALSE(runout.find("error_motion", "total_error_motion_um")->u);
  EXPECT_EQ(runout.group("revolution"), nullptr);  // the model's record, not figures
  ASSERT_TRUE(runout.revolution);
  EXPECT_EQ(runout.revolution->revolutions, std::optional<std::size_t>(20));
  EXPECT_EQ(runout.revolution->samples, 1001u);
  EXPECT_DOUBLE_EQ(runout.revolution->rpm, 60.0);
  EXPECT_DOUBLE_EQ(runout.revolution->covered_deg, 7201.11159648);
  EXPECT_TRUE(runout.runout_result);  // the model's result, typed: TheRecordsOfEveryKindAreTyped
  EXPECT_TRUE(runout.record.empty());

  const results::Params profile = results::params_from_json(golden("profile.params.json"));
  ASSERT_TRUE(profile.wavelet);
  EXPECT_EQ(profile.wavelet->wavelet, "db1");
  EXPECT_EQ(profile.wavelet->level, 5u);
  EXPECT_EQ(profile.wavelet->dominant_detail, "d4");
  ASSERT_EQ(profile.wavelet->bands.size(), 6u);
  EXPECT_EQ(profile.wavelet->bands[0].band, "a5");
  EXPECT_EQ(profile.wavelet->bands[0].coefficients, 313u);
  ASSERT_TRUE(profile.wavelet->bands[0].form_um);
  EXPECT_FALSE(profile.wavelet->bands[0].rms_um);  // the approximation: its form, no rms
  ASSERT_TRUE(profile.wavelet->bands[2].rms_um);
  EXPECT_DOUBLE_EQ(*profile.wavelet->bands[2].rms_um, 0.014145123333187619);
  EXPECT_FALSE(profile.wavelet->bands[2].form_um);

  const results::Params traverse = results::params_from_json(golden("straightness.params.json"));
  EXPECT_EQ(traverse.axis, "x");
  const results::Figure* h =
      traverse.find(results::horizontal_straightness.group, results::horizontal_straightness.figure_name);
  ASSERT_NE(h, nullptr);
  EXPECT_DOUBLE_EQ(h->value, 0.02703768606187836);
  EXPECT_TRUE(traverse.traverse_result);
  EXPECT_TRUE(traverse.record.empty());
}

// A run-out's, a traverse's and a profile's records besides their figures: read into their types (the one
// "result" key into the run-out's or the traverse's by the model it names), nothing left as JSON.
TEST(Params, TheRecordsOfEveryKindAreTyped) {
  const results::Params runout = results::params_from_json(golden("runout.params.json"));
  ASSERT_TRUE(runout.runout_result);
  EXPECT_FALSE(runout.traverse_result);
  const results::RunoutModelResult& r = *runout.runout_result;
  EXPECT_EQ(r.model, "squareness/runout");
  EXPECT_EQ(r.samples, 1001u);
  EXPECT_DOUBLE_EQ(r.runout_um, 0.29994005019810255);     // by its catalogue name, runout_um
  EXPECT_DOUBLE_EQ(r.amplitude_um, 0.14997002509905127);  // of "once_per_rev"
  EXPECT_DOUBLE_EQ(r.squareness_urad, r.deflection_urad);
  ASSERT_TRUE(r.travel_mm);
  EXPECT_DOUBLE_EQ(*r.travel_mm, 600.0);
  ASSERT_TRUE(r.error_motion);
  EXPECT_EQ(r.error_motion->revolutions, 20u);
  EXPECT_EQ(r.error_motion->points_per_rev, 50u);
  EXPECT_DOUBLE_EQ(r.error_motion->total_um, 0.554052488214334);

  const results::Params traverse = results::params_from_json(golden("straightness.params.json"));
  ASSERT_TRUE(traverse.traverse && traverse.traverse_result);
  EXPECT_FALSE(traverse.runout_result);
  EXPECT_EQ(traverse.traverse->stations, 13u);
  EXPECT_EQ(traverse.traverse->passes, 1u);
  EXPECT_EQ(traverse.traverse->axis, "x");
  const results::TraverseModelResult& t = *traverse.traverse_result;
  EXPECT_FALSE(t.source);  // a session's names no file
  EXPECT_EQ(t.instrument, "autocollimator");
  EXPECT_DOUBLE_EQ(t.instrument_range_arcsec, 600.0);
  ASSERT_TRUE(t.horizontal);
  EXPECT_DOUBLE_EQ(t.horizontal->least_squares.straightness_um, 0.02703768606187836);  // the figure's value
  EXPECT_TRUE(std::isnan(t.vertical.least_squares.u_straightness_data_um));            // null: the scatter is not known
  EXPECT_EQ(t.vertical.least_squares.max_station, 7u);
  EXPECT_EQ(t.vertical.u_disagreement, "");  // null
  EXPECT_EQ(t.vertical.polynomial.order, 6u);
  EXPECT_FALSE(t.vertical.polynomial.at_cap);
  ASSERT_EQ(t.vertical.stations.size(), 14u);  // the readings and the last foot
  EXPECT_DOUBLE_EQ(t.vertical.stations[3].height_um, 29.995422850064323);

  const results::Params profile = results::params_from_json(golden("profile.params.json"));
  ASSERT_TRUE(profile.points);
  EXPECT_EQ(profile.points->count, 10001u);
  EXPECT_DOUBLE_EQ(profile.points->length_mm, 10.0);
  ASSERT_TRUE(profile.profile_id);
  EXPECT_EQ(*profile.profile_id, results::ProfileId(29.0));  // an older release's "29.0", written back as such
  EXPECT_EQ(results::profile_id_json(std::uint64_t{29}).dump(), "29");

  // A "result" naming another model is no record this release types: kept as it came.
  const results::Params other = results::params_from_json(nlohmann::json::parse(R"({"result":{"model":"m","x":1}})"));
  EXPECT_FALSE(other.runout_result || other.traverse_result);
  EXPECT_EQ(other.record.dump(), R"({"result":{"model":"m","x":1}})");
}

TEST(Params, NullIsNaNAndWrittenBackAsNull) {
  const results::Params p =
      results::params_from_json(nlohmann::json::parse(R"({"model":"m","g":{"a_um":{"value":null,"u":null}}})"));
  ASSERT_NE(p.find("g", "a_um"), nullptr);
  EXPECT_TRUE(std::isnan(p.find("g", "a_um")->value));
  ASSERT_TRUE(p.find("g", "a_um")->u);
  EXPECT_TRUE(std::isnan(*p.find("g", "a_um")->u));
  EXPECT_EQ(results::to_json(p).dump(), R"({"g":{"a_um":{"u":null,"value":null}},"model":"m"})");
  // An object whose members carry more than a figure's keys is the model's record, kept as it is.
  const std::string result = R"({"result":{"backlash":{"axis":"x","value":1.0}}})";
  const results::Params s = results::params_from_json(nlohmann::json::parse(result));
  EXPECT_TRUE(s.groups.empty());
  EXPECT_FALSE(s.dbb);
  EXPECT_EQ(results::to_json(s).dump(), result);
}

TEST(Params, AMalformedPayloadIsRefusedNamingTheField) {
  EXPECT_EQ(refusal(R"({"diagnostics":{"circular_deviation_um":{"value":"17 um"}}})"),
            "diagnostics.circular_deviation_um: \"value\" is string, expected a number or null");
  EXPECT_EQ(refusal(R"({"lai3":{"backlash_x_um":{"value":1.0,"u":[1]}}})"),
            "lai3.backlash_x_um: \"u\" is array, expected a number or null");
  EXPECT_EQ(refusal(R"({"lai3":{"backlash_x_um":{"value":1.0,"not_determined":5}}})"),
            "lai3.backlash_x_um: \"not_determined\" is number, expected a text");
  EXPECT_EQ(refusal(R"({"plane":5})"), "\"plane\" is number, expected a text");
  EXPECT_EQ(refusal("[1,2]"), "a PARAMS is an object, not array");
  EXPECT_EQ(refusal(R"({"plane":"~x","diagnostics":{}})"), "");  // a text: whether it is a plane is the reader's
}

TEST(Params, DbbRecordIsTyped) {
  const results::Params p = results::params_from_json(golden("dbb.params.json"));
  ASSERT_TRUE(p.dbb);
  const results::DbbRecord& r = *p.dbb;
  ASSERT_EQ(r.runs.size(), 3u);
  EXPECT_EQ(r.runs[0].source, "pattern 1");
  EXPECT_EQ(r.runs[0].direction, "cw");
  EXPECT_DOUBLE_EQ(r.runs[0].radius_mm, 95.0);
  EXPECT_DOUBLE_EQ(r.runs[0].height_mm, 31.225);
  EXPECT_EQ(r.runs[0].n, 1791u);
  EXPECT_FALSE(r.runs[0].data_arc_deg);  // the full circle
  EXPECT_EQ(r.runs[0].gaps, 0u);
  EXPECT_EQ(r.ranking_model, "lai3");
  ASSERT_EQ(r.ranking.size(), 8u);
  EXPECT_EQ(r.ranking[0].name, "y_straightness_in_z");
  EXPECT_DOUBLE_EQ(r.ranking[0].percent_of_circular_deviation, 17.066363247279355);
  EXPECT_EQ(r.notes.size(), 2u);
  EXPECT_EQ(r.fit.n, 5464u);
  EXPECT_EQ(r.fit.unidentifiable.size(), 7u);
  ASSERT_EQ(r.fit.combinations.size(), 5u);
  EXPECT_EQ(r.fit.combinations[0].expression, "a1_rad + 320.256*c1_per_mm");
  EXPECT_DOUBLE_EQ(r.fit.condition_number, 7099960627053876.0);
  EXPECT_EQ(r.diagnostics_fit.n, 0u);  // no h = 0 pair: not fitted
  ASSERT_EQ(r.standards.runs.size(), 3u);
  ASSERT_EQ(r.standards.pairs.size(), 1u);
  EXPECT_EQ(r.standards.pairs[0].ccw_run, 2u);
  EXPECT_EQ(r.standards.pairs[0].cw_run, 1u);
  EXPECT_DOUBLE_EQ(r.standards.runs[0].iso_radial_deviation_max_um, -18.85656100785464);  // by its catalogue name
  const results::DbbTestConditions& c = r.standards.runs[2].conditions;
  EXPECT_EQ(c.samples, 1885u);
  ASSERT_TRUE(c.feed_in_deg);
  EXPECT_DOUBLE_EQ(*c.feed_in_deg, 44.261946);
  EXPECT_FALSE(c.temperature_c);  // "not recorded"
  EXPECT_FALSE(r.summary);
}

// What the golden file does not hold: a partial arc with gaps, a part of G that is null, an infinite condition
// number, and the machine across several planes: each written again byte for byte.
TEST(Params, DbbRecordOfSeveralPlanesIsWrittenAgainByteForByte) {
  nlohmann::json message = golden("dbb.params.json");
  message["runs"][0]["data_arc_deg"] = 220.0;
  message["runs"][0]["gaps"] = 2;
  message["ranking"][1]["percent_of_circular_deviation"] = nullptr;
  message["diagnostics_fit"]["condition_number"] = "inf";
  message["diagnostics_fit"]["why"] = {"a1_rad: the arc holds no reversal of x"};
  message["summary"] = nlohmann::json::parse(R"({
    "backlash": {"backlash_z_um": {"axis": "z", "consistent": false, "from": [{"plane": "xz", "u": 0.1, "value": 2.0},
                 {"plane": "yz", "value": 2.5}], "note": "the planes disagree", "u": 0.2, "value": 2.2}},
    "circular_deviation_um": 5.5, "notes": ["yz: no h = 0 pair"], "planes": ["xy", "xz", "yz"],
    "ranking": [{"contribution_um": 1.5, "name": "backlash_z_um", "percent_of_circular_deviation": null,
                 "plane": "xz"}],
    "scale": {}, "scale_mismatch": {"scale_mismatch_xy_ppm": {"value": 3.0}},
    "squareness": {"squareness_xz_urad": {"u": 0.5, "value": 20.0}}})");
  message["planes"] = {{"xy", body_of(golden("dbb.params.json"))}, {"yz", {{"error", "no complete circle"}}}};
  const results::Params p = results::params_from_json(message);
  ASSERT_EQ(p.planes.size(), 2u);
  ASSERT_TRUE(p.planes.at("xy").params);
  EXPECT_EQ(p.planes.at("xy").params->dbb->runs.size(), 3u);
  EXPECT_FALSE(p.planes.at("yz").params);
  EXPECT_EQ(p.planes.at("yz").error, "no complete circle");
  ASSERT_TRUE(p.dbb && p.dbb->summary);
  EXPECT_EQ(p.dbb->runs[0].data_arc_deg, 220.0);
  EXPECT_TRUE(std::isnan(p.dbb->ranking[1].percent_of_circular_deviation));
  EXPECT_EQ(p.dbb->diagnostics_fit.condition_number, std::numeric_limits<double>::infinity());
  const results::DbbAxisFigure& z = p.dbb->summary->backlash.at("backlash_z_um");
  EXPECT_FALSE(z.consistent);
  ASSERT_EQ(z.from.size(), 2u);
  EXPECT_EQ(z.from[1].first, "yz");
  EXPECT_FALSE(z.from[1].second.u);
  EXPECT_EQ(results::to_json(p).dump(), body_of(message).dump());
}

TEST(Params, AMalformedDbbRecordIsRefusedNamingTheField) {
  EXPECT_EQ(refusal(R"({"runs":[{"radius_mm":"95 mm"}]})"),
            "runs[0]: \"radius_mm\" is string, expected a number or null");
  EXPECT_EQ(refusal(R"({"runs":[{"n":-3}]})"), "runs[0]: \"n\" is number, expected a whole number, 0 or more");
  EXPECT_EQ(refusal(R"({"ranking":{}})"), "\"ranking\" is object, expected an array");
  EXPECT_EQ(refusal(R"({"fit":{"condition_number":"large"}})"),
            "fit: \"condition_number\" is string, expected a number or \"inf\"");
  EXPECT_EQ(refusal(R"({"standards":{"runs":[{"conditions":{"temperature_c":"warm"}}]}})"),
            "standards.runs[0].conditions: \"temperature_c\" is string, expected a number or \"not recorded\"");
  EXPECT_EQ(refusal(R"({"summary":{"backlash":{"backlash_z_um":[]}}})"),
            "summary.backlash.backlash_z_um is array, expected an object");
  EXPECT_EQ(refusal(R"({"planes":[]})"), "\"planes\" is array, expected an object");
  EXPECT_EQ(refusal(R"({"planes":{"xz":{"error":5}}})"), "planes.xz: \"error\" is number, expected a text");
  EXPECT_EQ(refusal(R"({"planes":{"xz":{"runs":{}}}})"), "planes.xz: \"runs\" is object, expected an array");
  EXPECT_EQ(refusal(R"({"planes":{"xz":{"planes":{}}}})"), "planes.xz: a plane's PARAMS holds no planes of its own");
  EXPECT_EQ(refusal(R"({"revolution":{"rpm":"60"}})"), "revolution: \"rpm\" is string, expected a number or null");
  EXPECT_EQ(refusal(R"({"revolution":[]})"), "revolution is array, expected an object");
  EXPECT_EQ(refusal(R"({"wavelet":{"bands":[{"band":"d1","rms_um":"1"}]}})"),
            "wavelet.bands[0]: \"rms_um\" is string, expected a number or null");
  EXPECT_EQ(refusal(R"({"wavelet":{"level":-5}})"), "wavelet: \"level\" is number, expected a whole number, 0 or more");
  EXPECT_EQ(refusal(R"({"result":{"model":"squareness/runout","once_per_rev":{"phase_deg":"east"}}})"),
            "result.once_per_rev: \"phase_deg\" is string, expected a number or null");
  EXPECT_EQ(refusal(R"({"result":{"model":"squareness/runout","error_motion":[]}})"),
            "result: \"error_motion\" is array, expected an object");
  EXPECT_EQ(refusal(R"({"result":{"model":"straightness/autocollimator","vertical":{"polynomial":{"order":1.5}}}})"),
            "result.vertical.polynomial: \"order\" is number, expected a whole number, 0 or more");
  EXPECT_EQ(refusal(R"({"result":{"model":"straightness/autocollimator","horizontal":{"u_disagreement":3}}})"),
            "result.horizontal: \"u_disagreement\" is number, expected a text or null");
  EXPECT_EQ(refusal(R"({"traverse":{"axis":1}})"), "traverse: \"axis\" is number, expected a text");
  EXPECT_EQ(refusal(R"({"points":{"count":"many"}})"),
            "points: \"count\" is string, expected a whole number, 0 or more");
  EXPECT_EQ(refusal(R"({"profile_id":"29"})"), "\"profile_id\" is string, expected a number");
}

// Any node of a real PARAMS replaced by a value of any type: read, or refused with the reason; never another
// exception (nlohmann's type_error, out_of_range) and never a crash.
TEST(Params, AnyFieldOfAnyTypeIsReadOrRefusedWithTheReason) {
  using nlohmann::json;
  std::mt19937_64 rng(43);
  const auto pick = [&](int n) { return std::uniform_int_distribution<int>(0, n - 1)(rng); };
  const json values[] = {nullptr, true, -4, 2.5, "t", json::array({1, "a", nullptr}), json{{"value", 1}}};
  std::vector<json> messages;
  std::vector<std::vector<json::json_pointer>> nodes;
  for (const char* kind : {"dbb", "runout", "profile", "straightness"}) {
    messages.push_back(golden(std::string(kind) + ".params.json"));
    nodes.push_back(test::node_pointers(messages.back()));
  }
  int refused = 0, read = 0;
  for (int i = 0; i < 2000; ++i) {
    const std::size_t m = static_cast<std::size_t>(pick(static_cast<int>(messages.size())));
    json j = messages[m];
    const std::vector<json::json_pointer>& all = nodes[m];
    for (int k = 1 + pick(2); k > 0; --k) {
      try {
        j[all[static_cast<std::size_t>(pick(static_cast<int>(all.size())))]] = values[pick(7)];
      } catch (const json::exception&) {  // a node inside one the first change replaced
      }
    }
    try {
      (void)results::to_json(results::params_from_json(j));
      ++read;
    } catch (const results::ParamsFormatError& e) {
      EXPECT_GT(std::string(e.what()).size(), 10u);
      ++refused;
    } catch (const std::exception& e) {
      ADD_FAILURE() << "not a ParamsFormatError: " << e.what() << " on " << j.dump();
    }
  }
  EXPECT_GT(refused, 100);
  EXPECT_GT(read, 100);
}
