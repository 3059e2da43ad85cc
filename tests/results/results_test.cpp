// The vocabulary of results (results/): the catalogue of parameters (names filled for a plane, found back
// from a reported name, one entry per group and name, units from the one table), the session kinds as
// data (options with their defaults, headline figures in order) and the PARAMS/EXPLAIN header.
#include <set>
#include <string>

#include <gtest/gtest.h>

#include "results/message_class.hpp"
#include "results/parameters.hpp"
#include "results/result_header.hpp"
#include "results/session_kinds.hpp"

using namespace guideway;

TEST(Results, ParameterNamesAreFilledForThePlane) {
  EXPECT_EQ(results::name(results::backlash, "xy", 0), "backlash_x_um");
  EXPECT_EQ(results::name(results::backlash, "xz", 1), "backlash_z_um");
  EXPECT_EQ(results::name(results::backlash, "yz", 0), "backlash_y_um");
  EXPECT_EQ(results::label(results::backlash, "xz", 1), "backlash Z");
  EXPECT_EQ(results::name(results::straightness_cubic_difference, "yz"), "straightness_cubic_y_minus_z_um");
  EXPECT_EQ(results::name_along(results::vibration, "bar"), "vibration_bar_um");
  EXPECT_EQ(results::name_along(results::centre_drift_offset, "x", 3), "drift_x_offset_run3_um");
  EXPECT_EQ(results::run_prefixed(2, "center_offset_x_um"), "run2.center_offset_x_um");
  EXPECT_EQ(results::run_suffixed("vibration_phase_x_deg", 2), "vibration_phase_x_deg_run2");
  EXPECT_EQ(results::axis_letter("xz", 1), "z");
  EXPECT_TRUE(results::per_axis(results::scale));
  EXPECT_FALSE(results::per_axis(results::squareness));
}

TEST(Results, ReportedNamesAreFoundInTheCatalogue) {
  EXPECT_EQ(results::find_parameter("backlash_z_um"), &results::backlash);
  EXPECT_EQ(results::find_parameter("run2.center_offset_x_um"), &results::center_offset);
  EXPECT_EQ(results::find_parameter("vibration_phase_bar_deg_run1"), &results::vibration_phase);
  EXPECT_EQ(results::find_parameter("straightness_cubic_x_minus_y_um"), &results::straightness_cubic_difference);
  EXPECT_EQ(results::find_parameter("straightness_cubic_y_um"), &results::straightness_cubic);
  EXPECT_EQ(results::find_parameter("S_x"), &results::lai_S_x);
  EXPECT_EQ(results::find_parameter("no_such_um"), nullptr);
  EXPECT_EQ(results::find_parameter("backlash_xy_um"), &results::backlash) << "{axis} may be a word (\"bar\")";
}

TEST(Results, EachGroupNamesAParameterOnce) {
  std::set<std::pair<std::string, std::string>> seen;
  for (const results::Parameter* p : results::catalogue()) {
    SCOPED_TRACE(std::string(p->name));
    EXPECT_TRUE(seen.insert({std::string(p->group), std::string(p->name)}).second || p->group.empty());
    EXPECT_FALSE(p->label.empty());
    EXPECT_FALSE(p->meaning.empty());
    for (const results::Place& place : p->places) {
      EXPECT_TRUE(seen.insert({std::string(place.group), std::string(place.name)}).second) << place.name;
      EXPECT_NE(place.group, p->group) << "a place is another group than its entry's";
    }
    if (!p->figure_name.empty()) {
      EXPECT_NE(p->headline, 0) << "a figure named apart is a headline's";
      EXPECT_EQ(results::find_parameter(p->figure_name, p->group), nullptr) << "its figure is no other entry's";
    }
  }
}

// One entry per physical quantity, with the places it is reported in as attributes: the DBB backlash is the
// diagnostics', Lai's (his x and y: the plane's axes), "what to fix first"'s and the machine's across its planes.
TEST(Results, OneEntryPerQuantityNamedInEachPlaceItIsReportedIn) {
  EXPECT_EQ(results::name_in(results::backlash, results::diagnostics_group, "zx", 0), "backlash_z_um");
  EXPECT_EQ(results::name_in(results::backlash, results::lai3_group, "zx", 0), "backlash_x_um");
  EXPECT_EQ(results::name_in(results::backlash, results::ranking_group, "zx", 1), "backlash_y");
  EXPECT_EQ(results::name_in(results::backlash, results::planes_group, "zx", 0), "backlash_z_um");
  EXPECT_EQ(results::name_in(results::backlash, "standards"), "");
  EXPECT_EQ(results::name_in(results::squareness, results::planes_group, "yz"), "squareness_yz_urad");
  EXPECT_EQ(results::name_in(results::scale_mismatch, results::ranking_group), "scale_mismatch");
  EXPECT_EQ(results::name_in(results::servo_mismatch, results::lai3_group), "servo_mismatch_ms");
  EXPECT_EQ(results::find_parameter("backlash_x_um", results::lai3_group), &results::backlash);
  EXPECT_EQ(results::find_parameter("backlash_y", results::ranking_group), &results::backlash);
  EXPECT_EQ(results::find_parameter("backlash_y"), &results::backlash);
  EXPECT_EQ(results::find_parameter("servo_mismatch_ms", results::lai3_group), &results::servo_mismatch);
  EXPECT_EQ(results::find_parameter("scale_mismatch_xz_ppm"), &results::scale_mismatch);
  EXPECT_EQ(results::find_parameter("squareness_yz_urad", results::planes_group), &results::squareness);
  EXPECT_EQ(results::find_parameter("scale_z_ppm", results::planes_group), &results::scale);
  EXPECT_EQ(results::label_of("squareness_yz_urad", "yz", results::planes_group), "squareness YZ");
  EXPECT_EQ(results::label_of("scale_mismatch_xz_ppm", "xz", results::planes_group), "scale mismatch XZ");
  EXPECT_EQ(results::label_of("scale_mismatch", "xy", results::ranking_group), "scale mismatch");
  EXPECT_EQ(results::label_of("backlash_x", "zx", results::ranking_group), "backlash Z");
  // People read Lai's backlash and servo mismatch after his last straightness coefficient, e3.
  const auto at = [](const char* name) { return results::shown_order(name, results::lai3_group); };
  EXPECT_LT(at("e3_per_mm2"), at("backlash_x_um"));
  EXPECT_EQ(at("backlash_x_um"), at("backlash_y_um"));
  EXPECT_EQ(at("backlash_y_um"), at("servo_mismatch_ms"));
  EXPECT_LT(at("servo_mismatch_ms"), at("mismatch_phase_angle_deg"));
  EXPECT_LT(at("S_x"), at("e3_per_mm2"));
  EXPECT_EQ(at("no_such_um"), static_cast<double>(results::catalogue().size()));
}

TEST(Results, UnitsComeFromTheNamesEnd) {
  EXPECT_EQ(results::unit(results::backlash), "\u00b5m");
  EXPECT_EQ(results::unit(results::squareness), "\u00b5rad");
  EXPECT_EQ(results::unit(results::scale), "ppm");
  EXPECT_EQ(results::unit(results::lai_a3), "1/mm\u00b2");
  EXPECT_EQ(results::split_unit("radius_mm"), std::make_pair(std::string("radius"), std::string("mm")));
  EXPECT_EQ(results::split_unit("S_x"), std::make_pair(std::string("S_x"), std::string()));
}

TEST(Results, ValuesAreShownInWordsAndUnitsThatMeanSomething) {
  // Lai's names say x and y for the plane's axes: the labels say which axes they are.
  EXPECT_EQ(results::label_of("y_straightness_in_z"), "Y straightness along Z");
  EXPECT_EQ(results::label_of("y_straightness_in_z", "xz"), "Z straightness along Y");
  EXPECT_EQ(results::label_of("backlash_y", "yz"), "backlash Z");
  EXPECT_EQ(results::label_of("backlash_y_um", "xz", "lai3"), "backlash Z");
  EXPECT_EQ(results::label_of("backlash_y_um", "xz", "diagnostics"), "backlash Y");
  EXPECT_EQ(results::label_of("vibration_bar_um"), "vibration bar");
  EXPECT_EQ(results::label_of("run2.center_offset_x_um"), "centre offset X (run 2)");
  EXPECT_EQ(results::label_of("bar_drift_offset_run3_um"), "bar drift offset run 3");
  EXPECT_EQ(results::label_of("horizontal_end_point_um"), "horizontal end point");
  // A scale factor as ppm off 1, Lai's coefficients per mm as micrometres per metre.
  auto s = results::shown("S_x", 0.9996776407483423, 4.069415599581395e-08);
  EXPECT_EQ(s.label, "scale X (S_x - 1)");
  EXPECT_EQ(s.value, "-322.359 \u00b1 0.041");
  EXPECT_EQ(s.unit, "ppm");
  s = results::shown("a2_per_mm", 2.2105014905903179e-07, 1.3290773841739774e-09);
  EXPECT_EQ(s.value, "221.1 \u00b1 1.3");
  EXPECT_EQ(s.unit, "\u00b5m/m\u00b2");
  s = results::shown("e1_rad", 1.9978019374005592e-06, 3.8883399429594204e-07);
  EXPECT_EQ(s.value, "2.00 \u00b1 0.39");
  EXPECT_EQ(s.unit, "\u00b5rad");
  s = results::shown("backlash_x_um", 0.9956473599246491, 0.008036227194117824);
  EXPECT_EQ(s.value, "0.9956 \u00b1 0.0080");
  EXPECT_EQ(s.unit, "\u00b5m");
  s = results::shown("circular_deviation_um", 17.417894088049465, NAN);
  EXPECT_EQ(s.label, "G");
  EXPECT_EQ(s.value, "17.4");
  EXPECT_EQ(results::shown_unit("tool_wear_um_per_m").symbol, "\u00b5m/m");
  EXPECT_EQ(results::shown_unit("bar_drift_um_per_min").symbol, "\u00b5m/min");
}

// A line fitted beside as its sine and cosine parts is read as its amplitude and phase, named in the catalogue.
TEST(Results, ALinesPartsNameItsAmplitudeAndPhase) {
  const auto v = results::line_of_part("vibration_cos_run2");
  ASSERT_TRUE(v.has_value());
  EXPECT_EQ(v->sine, "vibration_sin_run2");
  EXPECT_EQ(v->cosine, "vibration_cos_run2");
  EXPECT_EQ(v->amplitude, "vibration_amplitude_um_run2");
  EXPECT_EQ(v->phase, "vibration_phase_deg_run2");
  EXPECT_EQ(results::label_of(v->amplitude), "vibration amplitude (run 2)");
  EXPECT_EQ(results::shown("vibration_phase_deg", 12.34, 5.6).label, "vibration phase at t = 0");
  EXPECT_EQ(results::shown("vibration_amplitude_um", 0.0123, 0.0019).unit, "\u00b5m");
  const auto c = results::line_of_part("cyclic_sin_y");
  ASSERT_TRUE(c.has_value());
  EXPECT_EQ(c->cosine, "cyclic_cos_y");
  EXPECT_EQ(c->amplitude, "cyclic_error_y_um");
  EXPECT_EQ(c->phase, "cyclic_phase_y_deg");
  for (const char* none : {"vibration_x_um", "cyclic_sin_x_um", "drift_x_um_per_min", "vibration_amplitude_um"})
    EXPECT_FALSE(results::line_of_part(none).has_value()) << none;
}

TEST(Results, HeadlineFiguresAreInTheirKindsOrder) {
  const auto dbb = results::headlines(results::dbb_kind);
  ASSERT_EQ(dbb.size(), 4U);
  EXPECT_EQ(dbb[0], &results::circular_deviation);
  EXPECT_EQ(dbb[1], &results::squareness);
  EXPECT_EQ(dbb[2], &results::backlash);
  EXPECT_EQ(dbb[3], &results::scale);
  for (const results::SessionKindInfo* kind : results::session_kinds()) {
    SCOPED_TRACE(std::string(kind->name));
    EXPECT_FALSE(results::headlines(*kind).empty());
    for (const results::Parameter* p : results::headlines(*kind)) EXPECT_EQ(p->kind, kind->name);
  }
  EXPECT_TRUE(results::headline_parameters("unknown").empty());
}

TEST(Results, SessionKindsListTheirOptionsWithDefaults) {
  EXPECT_EQ(results::session_kind_names(), "dbb, runout, straightness, profile");
  EXPECT_EQ(results::session_kind_rank("runout"), 1);
  EXPECT_EQ(results::session_kind_rank("unknown"), 4);
  EXPECT_EQ(&results::session_kind("profile"), &results::profile_kind);
  EXPECT_THROW((void)results::session_kind("nope"), std::out_of_range);
  EXPECT_EQ(results::option_with_default(results::straightness_step_mm), "step_mm=18.75");
  EXPECT_EQ(results::option_with_default(results::straightness_start), "start=return|now (default return)");
  EXPECT_EQ(results::option_with_default(results::profile_wavelet), "wavelet=db1");
  const std::string d = results::description(results::runout_kind);
  EXPECT_NE(d.find("(options: plate_diameter_mm=1000, parallelism_um=2.5,"), std::string::npos) << d;
  for (const results::SessionKindInfo* kind : results::session_kinds()) {
    std::set<std::string_view> names;
    for (const results::SessionOption* o : kind->options) {
      EXPECT_TRUE(names.insert(o->name).second) << o->name;
      EXPECT_FALSE(o->help.empty()) << o->name;
      if (o->type == results::OptionType::number || o->type == results::OptionType::integer) {
        EXPECT_LE(o->min, o->fallback) << o->name;
        EXPECT_LE(o->fallback, o->max) << o->name;
      }
    }
  }
}

TEST(Results, HeaderIsWrittenWithoutEmptyFieldsAndReadBack) {
  results::ResultHeader h;
  h.session = "dbb-dbb-1";
  h.kind = "dbb";
  h.device = "dbb";
  h.samples = 12;
  h.derived = {"a.csv"};
  const nlohmann::json j = results::with_header({{"model", "m"}}, h);
  EXPECT_EQ(j.dump(),
            R"({"derived":["a.csv"],"device":"dbb","kind":"dbb","model":"m","samples":12,"session":"dbb-dbb-1"})");
  const results::ResultHeader back = results::read_header(j);
  EXPECT_EQ(back.session, h.session);
  EXPECT_EQ(back.samples, h.samples);
  EXPECT_EQ(back.derived, h.derived);
  EXPECT_TRUE(back.recording.empty());
  EXPECT_TRUE(results::read_header(nlohmann::json::array()).session.empty());
}

TEST(Results, MessageClassesByName) {
  EXPECT_EQ(results::class_named("VERSION"), results::MessageClass::version);
  EXPECT_EQ(results::class_named("PORT"), results::MessageClass::port);
  EXPECT_FALSE(results::published_class("PORT"));
  EXPECT_EQ(results::request(results::RequestClass::params, {{"kind", "dbb"}}).dump(),
            R"({"class":"params","kind":"dbb"})");
  EXPECT_EQ(results::request_named("recordings"), results::RequestClass::recordings);
  EXPECT_FALSE(results::request_named("STATUS")) << "requests are lower case";
  EXPECT_EQ(results::request_class_names(),
            "version, status, poll, watch, start, stop, params, explain, report, recordings");
  EXPECT_TRUE(results::has_class(results::with_class(results::MessageClass::params, nlohmann::json::object()),
                                 results::MessageClass::params));
  EXPECT_FALSE(results::has_class(nlohmann::json::array(), results::MessageClass::params));
  EXPECT_FALSE(results::has_class({{"class", 3}}, results::MessageClass::params));
}
