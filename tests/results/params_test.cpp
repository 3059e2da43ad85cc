// PARAMS as a type (results/params.hpp): the golden PARAMS of every session kind read and written again byte
// for byte, their figures named by their catalogue entries, and what params_from_json refuses, naming the field.
#include <cmath>
#include <fstream>
#include <iterator>
#include <sstream>
#include <string>

#include <gtest/gtest.h>
#include <nlohmann/json.hpp>

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
  EXPECT_TRUE(dbb.record.contains("runs"));
  EXPECT_TRUE(dbb.record.contains("standards"));
  EXPECT_FALSE(dbb.record.contains("lai3"));
  EXPECT_FALSE(dbb.record.contains("session"));  // the header is not the body's

  const results::Params runout = results::params_from_json(golden("runout.params.json"));
  EXPECT_EQ(runout.find("squareness", "runout_um")->entry, &results::runout);
  EXPECT_EQ(runout.find("squareness", "squareness_urad")->entry, &results::runout_squareness);
  EXPECT_EQ(runout.find("squareness", "once_per_rev_amplitude_um")->entry, nullptr);
  EXPECT_EQ(runout.find("error_motion", "total_error_motion_um")->entry, &results::total_error_motion);
  EXPECT_FALSE(runout.find("error_motion", "total_error_motion_um")->u);
  EXPECT_EQ(runout.group("revolution"), nullptr);  // the model's record, not figures
  EXPECT_EQ(runout.record["revolution"]["revolutions"], 20);

  const results::Params traverse = results::params_from_json(golden("straightness.params.json"));
  EXPECT_EQ(traverse.axis, "x");
  const results::Figure* h =
      traverse.find(results::horizontal_straightness.group, results::horizontal_straightness.figure_name);
  ASSERT_NE(h, nullptr);
  EXPECT_DOUBLE_EQ(h->value, 0.02703768606187836);
  EXPECT_TRUE(traverse.record.contains("result"));
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
  const std::string summary = R"({"summary":{"backlash":{"axis":"x","value":1.0}}})";
  const results::Params s = results::params_from_json(nlohmann::json::parse(summary));
  EXPECT_TRUE(s.groups.empty());
  EXPECT_EQ(results::to_json(s).dump(), summary);
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
