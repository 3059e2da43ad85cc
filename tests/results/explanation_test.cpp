// results/explanation: EXPLAIN's body as one type with one JSON writer and one reader. The reader gives back
// what the writer wrote (random explanations, through the text too); the writer writes what the golden
// EXPLAIN messages hold, byte for byte; a malformed payload (as a broker or a file may bring) is an
// ExplanationFormatError naming the field, never another exception.
#include <cmath>
#include <fstream>
#include <random>
#include <sstream>
#include <string>
#include <tuple>
#include <vector>

#include <gtest/gtest.h>
#include <nlohmann/json.hpp>

#include "json_nodes.hpp"
#include "results/explanation.hpp"

using namespace guideway;
using nlohmann::json;

namespace {

// Random explanations. `with_nan`: some numbers NaN (null on the wire), which == never finds equal.
class Generator {
 public:
  explicit Generator(std::uint64_t seed) : rng_(seed) {}

  results::Explanation explanation(bool with_nan) {
    with_nan_ = with_nan;
    results::Explanation e;
    e.model = text();
    e.notes = texts();
    if (pick(6) == 0) {  // the short form: only these fields are in its JSON
      e.not_analysed = text() + "x";
      e.unexplained = pick(2) == 0;
      return e;
    }
    e.n = count();
    e.set_aside_samples = pick(3) == 0 ? count() : 0;
    e.noise_um = number();
    e.heldout_scheme = text();
    e.baseline = fit();
    e.final_fit = fit();
    e.mismatch = places();
    e.remaining = places();
    for (int k = pick(4); k > 0; --k) e.findings.push_back(finding());
    for (int k = pick(4); k > 0; --k) e.considered.push_back({text(), number(), number(), text()});
    e.unexplained = pick(2) == 0;
    if (pick(2) == 0) e.deviation = results::ExplainDeviation{text(), finite()};
    if (pick(2) == 0) {
      results::ExplainResiduals r{text(), numbers(5), texts(), {}};
      for (int k = pick(3); k > 0; --k) r.steps.push_back({text(), {numbers(5), numbers(5)}});
      e.residuals = r;
    }
    return e;
  }

 private:
  int pick(int n) { return std::uniform_int_distribution<int>(0, n - 1)(rng_); }
  double finite() {
    switch (pick(4)) {
      case 0:
        return std::uniform_int_distribution<int>(-1000, 1000)(rng_);  // whole: written as 3.0, read back a double
      case 1:
        return std::ldexp(std::uniform_real_distribution<double>(-1, 1)(rng_), pick(600) - 300);
      default:
        return std::uniform_real_distribution<double>(-1e3, 1e3)(rng_);
    }
  }
  double number() { return with_nan_ && pick(5) == 0 ? std::nan("") : finite(); }
  std::vector<double> numbers(std::size_t n) {
    std::vector<double> v(n);
    for (double& x : v) x = number();
    return v;
  }
  std::size_t count() { return std::uniform_int_distribution<std::size_t>(1, std::size_t{1} << 40)(rng_); }
  std::string text() {
    static const std::vector<std::string> pieces = {"backlash",  " ",      "\u00b5m", "\"",   "\\", "\n",
                                                    "run2 (cw)", "\u2013", "{}",      "x_um", ""};
    std::string s;
    for (int k = pick(4); k > 0; --k) s += pieces[static_cast<std::size_t>(pick(static_cast<int>(pieces.size())))];
    return s;
  }
  std::vector<std::string> texts() {
    std::vector<std::string> v;
    for (int k = pick(3); k > 0; --k) v.push_back(text());
    return v;
  }
  results::ExplainFit fit() { return {number(), number(), number(), count()}; }
  std::vector<results::ExplainPlace> places() {
    std::vector<results::ExplainPlace> v;
    for (int k = pick(3); k > 0; --k) {
      results::ExplainPlace p{text(), text(), text(), text(), {}, {}};
      for (int r = pick(3); r > 0; --r) p.ranges.emplace_back(number(), number());
      for (int l = pick(3); l > 0; --l)
        p.locations.push_back({text(),
                               text(),
                               {number(), number()},
                               {number(), number()},
                               pick(2) == 0,
                               {number(), number()},
                               number(),
                               texts(),
                               pick(2) == 0});
      v.push_back(std::move(p));
    }
    return v;
  }
  results::ExplainFinding finding() {
    results::ExplainFinding f;
    f.effect = text();
    for (int k = pick(4); k > 0; --k) f.parameters[text() + std::to_string(k)] = {number(), number()};
    f.delta_bic = number();
    f.p_value = number();
    f.rms_um_after = number();
    f.heldout_rms_um_after = number();
    f.structure_removed = number();
    f.contribution_um = number();
    f.percent_of_deviation = number();
    f.why = text();
    return f;
  }

  std::mt19937_64 rng_;
  bool with_nan_ = false;
};

json golden(const std::string& name) {
  std::ifstream in(std::string(GUIDEWAY_SOURCE_DIR) + "/tests/golden/" + name);
  std::ostringstream s;
  s << in.rdbuf();
  return json::parse(s.str());
}

}  // namespace

TEST(Explanation, ReadsBackWhatItWrote) {
  Generator g(20261130);
  for (int i = 0; i < 400; ++i) {
    const results::Explanation e = g.explanation(false);
    const json j = results::to_json(e);
    const results::Explanation back = results::explanation_from_json(json::parse(j.dump()));  // through the text
    if (e.not_analysed.empty()) {
      EXPECT_EQ(results::explanation_from_json(j), e) << j.dump();
      EXPECT_EQ(back, e) << j.dump();
    } else {  // the short form holds these; its numbers are absent (NaN, which == never finds equal)
      EXPECT_EQ(std::tie(back.model, back.not_analysed, back.notes, back.unexplained),
                std::tie(e.model, e.not_analysed, e.notes, e.unexplained));
      EXPECT_TRUE(back.findings.empty());
      EXPECT_TRUE(std::isnan(back.noise_um));
    }
  }
}

TEST(Explanation, ReadsBackWhatItWroteWithNullsForNaN) {
  Generator g(7);
  for (int i = 0; i < 400; ++i) {
    const json j = results::to_json(g.explanation(true));
    const json again = results::to_json(results::explanation_from_json(json::parse(j.dump())));
    EXPECT_EQ(again.dump(), j.dump());
  }
  results::ExplainFinding searched;
  searched.effect = "vibration";
  searched.parameters["vibration_frequency_hz"] = {7.5, std::nan("")};  // found by a search on a grid
  results::Explanation e;
  e.findings = {searched};
  const json j = results::to_json(e);
  EXPECT_TRUE(j["findings"][0]["parameters"]["vibration_frequency_hz"]["u"].is_null()) << j.dump();
  EXPECT_TRUE(j["noise_um"].is_null());
  EXPECT_TRUE(std::isnan(results::explanation_from_json(j).findings[0].parameters.at("vibration_frequency_hz").u));
}

// The golden EXPLAIN messages were written by the daemon before the type existed: its writer gives them
// back byte for byte (their header aside), the short form of a session not analysed included.
TEST(Explanation, WritesTheGoldenMessagesByteForByte) {
  for (const std::string kind : {"dbb", "runout", "straightness", "profile"}) {
    SCOPED_TRACE(kind);
    json message = golden(kind + ".explain.json");
    const results::Explanation e = results::explanation_from_json(message);
    for (const char* header : {"class", "session", "kind", "device", "samples", "recording", "recording_error",
                               "derived", "replayed_from", "instrument"})
      message.erase(header);
    EXPECT_EQ(results::to_json(e).dump(1), message.dump(1));
  }
  const results::Explanation dbb = results::explanation_from_json(golden("dbb.explain.json"));
  ASSERT_EQ(dbb.findings.size(), 2u);
  EXPECT_EQ(dbb.findings[0].effect, "backlash");
  EXPECT_DOUBLE_EQ(dbb.findings[0].contribution_um, 1.9898527045693912);
  EXPECT_EQ(dbb.findings[0].parameters.count("backlash_x_um"), 1u);
  ASSERT_TRUE(dbb.residuals);
  EXPECT_EQ(dbb.residuals->steps.size(), 3u);
  EXPECT_FALSE(dbb.mismatch.empty());
  EXPECT_FALSE(dbb.mismatch[0].locations.empty());
}

TEST(Explanation, NotAnalysedIsTheDocumentedShortForm) {
  EXPECT_EQ(results::to_json(results::not_analysed("straightness", "too few stations")).dump(),
            R"({"findings":[],"model":"straightness","not_analysed":"too few stations",)"
            R"("notes":["not analysed: too few stations"],"unexplained":true})");
  EXPECT_TRUE(results::is_explanation(results::to_json(results::not_analysed("runout", "one turn"))));
  EXPECT_TRUE(results::is_explanation(golden("dbb.explain.json")));
  EXPECT_FALSE(results::is_explanation(json::parse(R"({"findings":[]})")));
  EXPECT_FALSE(results::is_explanation(json::parse(R"({"baseline":{},"findings":{}})")));
  EXPECT_FALSE(results::is_explanation(json::array()));
}

TEST(Explanation, FoundIsTheFindingsEffectsAndSizes) {
  const json dbb = golden("dbb.explain.json");
  json expected = {{"findings", json::array()}, {"unexplained", false}};
  for (const auto& f : dbb["findings"])
    expected["findings"].push_back({{"effect", f["effect"]}, {"contribution_um", f["contribution_um"]}});
  EXPECT_EQ(results::found_json(results::explanation_from_json(dbb)).dump(), expected.dump());
  EXPECT_EQ(results::found_json(results::not_analysed("runout", "one turn")).dump(),
            R"({"findings":[],"not_analysed":"one turn","unexplained":true})");
}

TEST(Explanation, AMalformedPayloadIsAnErrorNamingTheField) {
  const std::vector<std::pair<const char*, const char*>> cases = {
      {"[1,2]", "an explanation is a JSON object, not array"},
      {R"({"findings":{"effect":"backlash"}})", R"("findings" is object, expected an array)"},
      {R"({"findings":[5]})", "findings[0] is number, expected an object"},
      {R"({"findings":[{"effect":5}]})", R"(findings[0] needs "effect" as a text)"},
      {R"({"findings":[{"effect":"b"},{"effect":"c","contribution_um":"big"}]})",
       R"(findings[1]: "contribution_um" is string, expected a number or null)"},
      {R"({"findings":[{"effect":"b","parameters":{"x_um":{"value":"1"}}}]})",
       R"(findings[0].parameters.x_um: "value" is string, expected a number or null)"},
      {R"({"findings":[{"effect":"b","parameters":{"x_um":3}}]})",
       "findings[0].parameters.x_um is number, expected an object"},
      {R"({"unexplained":"yes"})", R"("unexplained" is string, expected true or false)"},
      {R"({"n":-3})", R"("n" is number, expected a whole number, 0 or more)"},
      {R"({"n":2.5})", R"("n" is number, expected a whole number, 0 or more)"},
      {R"({"baseline":[]})", R"("baseline" is array, expected an object)"},
      {R"({"final":{"rms_um":"1"}})", R"(final: "rms_um" is string, expected a number or null)"},
      {R"({"mismatch":[{"ranges":[[1]]}]})", "mismatch[0].ranges[0] must be two numbers (or nulls)"},
      {R"({"remaining":[{"locations":[{"where":[1,"a"]}]}]})",
       R"(remaining[0].locations[0]: "where" must be two numbers (or nulls))"},
      {R"({"residuals":{"steps":[{"residual_um":[[1,"x"]]}]}})",
       "residuals.steps[0].residual_um[0][1] is string, expected a number or null"},
      {R"({"residuals":{"runs":["a",2]}})", "residuals.runs[1] is number, expected a text"},
      {R"({"notes":[1]})", "notes[0] is number, expected a text"},
      {R"({"deviation":{"value_um":"7"}})", R"(deviation: "value_um" is string, expected a number or null)"},
      {R"({"considered":[{"verdict":false}]})", R"(considered[0]: "verdict" is boolean, expected a text)"},
  };
  for (const auto& [payload, message] : cases) {
    try {
      (void)results::explanation_from_json(json::parse(payload));
      ADD_FAILURE() << payload << ": no error";
    } catch (const results::ExplanationFormatError& e) {
      EXPECT_EQ(std::string(e.what()), message) << payload;
    }
  }
  // Absent keys take their defaults: the fleet's oldest messages, a header alone.
  const results::Explanation e = results::explanation_from_json(json::parse(R"({"findings":[{"effect":"spike"}]})"));
  ASSERT_EQ(e.findings.size(), 1u);
  EXPECT_TRUE(std::isnan(e.findings[0].contribution_um));
  const results::Explanation header_alone = results::explanation_from_json(json::parse(R"({"class":"EXPLAIN"})"));
  EXPECT_EQ(results::to_json(header_alone).dump(), results::to_json(results::Explanation{}).dump());
}

// Any node of a real explanation replaced by a value of any type: read, or refused with the reason; never
// another exception (nlohmann's type_error, out_of_range) and never a crash.
TEST(Explanation, AnyFieldOfAnyTypeIsReadOrRefusedWithTheReason) {
  Generator g(46);
  std::mt19937_64 rng(46);
  const auto pick = [&](int n) { return std::uniform_int_distribution<int>(0, n - 1)(rng); };
  const auto any_value = [&]() -> json {
    switch (pick(7)) {
      case 0:
        return nullptr;
      case 1:
        return pick(2) == 0;
      case 2:
        return pick(2000) - 1000;
      case 3:
        return 0.5 * pick(9);
      case 4:
        return "t" + std::to_string(pick(9));
      case 5:
        return json::array({1, "a", nullptr});
      default:
        return json{{"effect", "b"}, {"value", 1}};
    }
  };
  int refused = 0, read = 0;
  for (int i = 0; i < 1500; ++i) {
    json j = results::to_json(g.explanation(true));
    const std::vector<json::json_pointer> all = test::node_pointers(j);
    for (int k = 1 + pick(2); k > 0; --k) {
      try {
        j[all[static_cast<std::size_t>(pick(static_cast<int>(all.size())))]] = any_value();
      } catch (const json::exception&) {  // a node inside one the first change replaced
      }
    }
    try {
      (void)results::explanation_from_json(j);
      ++read;
    } catch (const results::ExplanationFormatError& e) {
      EXPECT_GT(std::string(e.what()).size(), 10u);
      ++refused;
    } catch (const std::exception& e) {
      ADD_FAILURE() << "not an ExplanationFormatError: " << e.what() << " on " << j.dump();
    }
  }
  EXPECT_GT(refused, 100);
  EXPECT_GT(read, 100);
}
