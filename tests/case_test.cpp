#include "geardyn/case.hpp"

#include <gtest/gtest.h>

#include <cmath>
#include <filesystem>
#include <fstream>

#include "geardyn/run.hpp"
#include "geardyn/train_case.hpp"
#include "test_support.hpp"

namespace geardyn {
namespace {

const std::filesystem::path kCases = std::filesystem::path(GEARDYN_SOURCE_DIR) / "cases";

using geardyn::testing::error_of;

TEST(Case, DefaultsAreTable1AndFig4c) {
  const Case c = load_case(std::nullopt);
  EXPECT_EQ(c.gear.normal_module_mm, 2.5);
  EXPECT_EQ(c.gear.helix_angle_deg, 20.0);
  EXPECT_EQ(c.gear.center_distance_mm, 150.0);
  EXPECT_EQ(c.gear.teeth[0], 56);
  EXPECT_EQ(c.gear.profile_shift[1], 0.2075);
  EXPECT_EQ(c.mesh.mean_stiffness_n_per_m, 2.34e8);
  EXPECT_EQ(c.mesh.backlash_um, 100.0);
  EXPECT_EQ(c.mesh.damping_ratio, 0.02);
  EXPECT_EQ(c.load.torque_nm, 49.5);
  EXPECT_EQ(c.load.fluctuation_ratio, 0.25);
  EXPECT_EQ(c.speed.shaft_frequency_hz, 1000.0);
  EXPECT_TRUE(c.mesh.stiffness_harmonics.empty());
  EXPECT_EQ(c.mesh.stiffness_source, StiffnessSource::kEnergy);
  EXPECT_EQ(c.mesh.harmonics_kept, 2);
}

TEST(Case, HarmonicsGivenWithoutASourceSelectTheHarmonicsSource) {
  const Case c = parse_case("[mesh]\nstiffness_harmonics = [[0.05, 0]]\n", "h.toml");
  EXPECT_EQ(c.mesh.stiffness_source, StiffnessSource::kHarmonics);
  const std::string msg = error_of([] {
    parse_case("[mesh]\nstiffness_source = \"energy\"\nstiffness_harmonics = [[0.05, 0]]\n",
               "h.toml");
  });
  EXPECT_NE(msg.find("h.toml:3"), std::string::npos) << msg;
  EXPECT_NE(msg.find("unless mesh.stiffness_source = \"harmonics\""), std::string::npos) << msg;
}

TEST(Case, ShippedPark2010FileEqualsTheDefaults) {
  const Case file = load_case(kCases / "park2010.toml");
  Case defaults;  // the file writes its method; a default one is left out (chosen per case)
  defaults.origins["solver.method"] = "the file";
  EXPECT_EQ(to_toml(defaults).substr(to_toml(defaults).find("[gear]")),
            to_toml(file).substr(to_toml(file).find("[gear]")));
  EXPECT_EQ(file.name, "park2010");
}

TEST(Case, RoundTripsThroughToml) {
  Case c;
  c.mesh.stiffness_source = StiffnessSource::kHarmonics;
  c.mesh.stiffness_harmonics = {{0.05, 10}, {0.02, -30}};
  c.mesh.tension = TensionRule::kClip;
  c.load.load_torque_nm = 40.0;
  c.gear.inertia_kg_m2 = std::array<double, 2>{0.01, 0.02};
  c.solver.initial = InitialCondition::kStatic;
  const Case back = parse_case(to_toml(c), "roundtrip");
  EXPECT_EQ(to_toml(back), to_toml(c));
}

TEST(Case, TomlNumbersAreTheShortestThatReadBackExactly) {
  // 154.98, not 154.97999999999999; floats keep a point (7850.0); an array element below 0.1
  // (where toml++ 3.3's own array formatting casts out of range) is written as itself; every
  // number reads back to the same double.
  Case c;
  c.mesh.stiffness_source = StiffnessSource::kHarmonics;
  c.mesh.stiffness_harmonics = {{0.05, 0.0}, {1.0 / 3.0, -1e-300}};
  c.speed.shaft_frequency_hz = 1234.5678901234567;
  const std::string text = to_toml(c);
  EXPECT_NE(text.find("outside_diameter_mm = [154.98, 154.98]"), std::string::npos) << text;
  EXPECT_NE(text.find("density_kg_m3 = 7850.0\n"), std::string::npos) << text;
  EXPECT_NE(text.find("[[0.05, 0.0], [0.3333333333333333, -1e-300]]"), std::string::npos) << text;
  EXPECT_EQ(text.find("99999"), std::string::npos) << text;
  const Case back = parse_case(text, "shortest");
  EXPECT_EQ(back.speed.shaft_frequency_hz, 1234.5678901234567);
  EXPECT_EQ(back.mesh.stiffness_harmonics[1].ratio, 1.0 / 3.0);
  EXPECT_EQ(back.mesh.stiffness_harmonics[1].phase_deg, -1e-300);
  c.description = "a \"quoted\" name\twith a tab, ü";
  EXPECT_EQ(parse_case(to_toml(c), "escapes").description, c.description);
}

// A control character in a --set (a newline pasted inside the shell's quotes) is refused as
// the --set it is, shown escaped on one line; one inside a TOML string (written \n) is read,
// and a message that echoes the value escapes it.
TEST(Case, AControlCharacterInASetIsNamedEscaped) {
  std::string msg = error_of([] { (void)parse_override("load.torque_nm=4\n9"); });
  EXPECT_NE(msg.find("--set load.torque_nm=4\\n9: holds the control character \\n at "
                     "character 17: a --set is one line"),
            std::string::npos)
      << msg;
  EXPECT_EQ(msg.find('\n'), std::string::npos) << msg;
  msg = error_of([] { (void)parse_override("mesh.stiffness_source=\"iso\x07\""); });
  EXPECT_NE(msg.find("holds the control character \\u0007 at character 27"), std::string::npos)
      << msg;
  msg = error_of([] {
    (void)load_case(std::nullopt, {parse_override("mesh.stiffness_source=\"iso\\n6336\"")});
  });
  EXPECT_NE(msg.find("mesh.stiffness_source = \"iso\\n6336\": must be one of"), std::string::npos)
      << msg;
  EXPECT_NE(msg.find("--set mesh.stiffness_source="), std::string::npos) << msg;
}

TEST(Case, TextTomlPlusPlusMishandlesIsRefusedFirst) {
  // toml++ 3.3 asserts on '[' followed by NUL and reaches an unreachable branch on non-ASCII
  // bare keys: both are invalid TOML, refused with where they are before toml++ sees them.
  std::string msg = error_of([] { parse_case(std::string("[mesh\0]\n", 8), "nul.toml"); });
  EXPECT_NE(msg.find("nul.toml:1:6: a NUL character"), std::string::npos) << msg;
  msg = error_of([] { parse_case("[gear]\nmodule_\xce\xbcm = 2\n", "key.toml"); });
  EXPECT_NE(msg.find("key.toml:2:8: a non-ASCII character outside a string"), std::string::npos)
      << msg;
  msg = error_of([] { load_case(std::nullopt, {parse_override("mesh.b\xc3\xbc=1")}); });
  EXPECT_NE(msg.find("non-ASCII"), std::string::npos) << msg;
  // In strings and comments non-ASCII text is TOML, and read as it is.
  const Case c = parse_case(
      "description = \"Zahnr\xc3\xa4"
      "der\" # \xc3\xbc\n[mesh] # '''\nbacklash_um = 120\n",
      "utf8.toml");
  EXPECT_EQ(c.description,
            "Zahnr\xc3\xa4"
            "der");
  EXPECT_EQ(c.mesh.backlash_um, 120.0);
  EXPECT_EQ(parse_case("description = '''\n[\xc3\xbc] = '''\n", "ml.toml").description,
            "[\xc3\xbc] = ");
}

TEST(Case, DerivedErrorsNameWhereTheirKeysCameFrom) {
  // The geometry is checked after reading; its errors still say where the values were given.
  const Case file = parse_case("[gear]\nface_width_mm = 1e308\n", "wide.toml");
  EXPECT_EQ(file.origins.at("gear.face_width_mm"), "wide.toml:2:17");
  std::string msg = error_of([&] { case_geometry(file); });
  EXPECT_NE(msg.find("(gear.face_width_mm from wide.toml:2:17)"), std::string::npos) << msg;
  Case set = load_case(std::nullopt, {parse_override("gear.outside_diameter_mm=[300,300]")});
  msg = error_of([&] { build_model(set); });
  EXPECT_NE(msg.find("(gear.outside_diameter_mm from --set gear.outside_diameter_mm=[300,300], "
                     "gear.normal_module_mm: default value"),
            std::string::npos)
      << msg;
  // A later override (a sweep's) is named as such; the others keep their origin.
  set_case_value(set, parse_override("gear.face_width_mm=1e308"));
  EXPECT_EQ(set.origins.at("gear.face_width_mm"), "--set gear.face_width_mm=1e308");
  EXPECT_EQ(set.origins.at("gear.outside_diameter_mm"), "--set gear.outside_diameter_mm=[300,300]");
  EXPECT_EQ(with_origins(Case{}, "no key of it"), "no key of it");
}

TEST(Case, AKeySetOnALoadedCaseIsRefusedCitingWhereTheOtherKeysCameFrom) {
  // A key that is not one number (a name, an array) is set by reading the case again from its
  // text; a refusal that names another key cites the user's file, --set or default for it,
  // never a place in that text ("(case):32:20").
  const Case file = parse_case(
      "[mesh]\nstiffness_source = \"harmonics\"\nstiffness_harmonics = [[0.1, 0]]\n", "h.toml");
  Case c = file;
  std::string msg = error_of([&] { set_case_value(c, {"mesh.stiffness_source", "\"energy\""}); });
  EXPECT_EQ(msg.rfind("h.toml:3:23: mesh.stiffness_harmonics = 1 harmonics: must be empty", 0), 0U)
      << msg;
  EXPECT_NE(msg.find("mesh.stiffness_source from --set mesh.stiffness_source=\"energy\""),
            std::string::npos)
      << msg;
  c = load_case(std::nullopt);
  msg = error_of([&] { set_case_value(c, {"mesh.stiffness_harmonics", "[[0.1, 0]]"}); });
  EXPECT_EQ(msg.rfind("--set mesh.stiffness_harmonics=[[0.1, 0]]: mesh.stiffness_harmonics", 0), 0U)
      << msg;
  EXPECT_NE(msg.find("(mesh.stiffness_source: default value)"), std::string::npos) << msg;
  for (const std::string& m : {msg, error_of([&] {
                                 Case d = file;
                                 set_case_value(d, {"mesh.stiffness_source", "\"energy\""});
                               })})
    EXPECT_EQ(m.find("(case)"), std::string::npos) << m;
  // Read again without a refusal, the keys keep their origins and the override has its own.
  c = file;
  set_case_value(c, {"mesh.stiffness_harmonics", "[[0.2, 10]]"});
  EXPECT_EQ(c.origins.at("mesh.stiffness_source"), "h.toml:2:20");
  EXPECT_EQ(c.origins.at("mesh.stiffness_harmonics"), "--set mesh.stiffness_harmonics=[[0.2, 10]]");
  EXPECT_EQ(c.origins.count("mesh.backlash_um"), 0U);  // a default
}

TEST(Case, OverridesUseTomlValueSyntax) {
  const Case c =
      load_case(std::nullopt,
                {parse_override("speed.shaft_frequency_hz=100"),
                 parse_override("mesh.stiffness_harmonics=[[0.05,0],[0.02,90]]"),
                 parse_override("mesh.tension=\"clip\""), parse_override("gear.teeth = [20, 40]")});
  EXPECT_EQ(c.speed.shaft_frequency_hz, 100.0);
  ASSERT_EQ(c.mesh.stiffness_harmonics.size(), 2u);
  EXPECT_EQ(c.mesh.stiffness_harmonics[1].phase_deg, 90.0);
  EXPECT_EQ(c.mesh.tension, TensionRule::kClip);
  EXPECT_EQ(c.gear.teeth[1], 40);
}

TEST(Case, SetCaseValueAmendsALoadedCase) {
  Case c;
  c.name = "mine";
  set_case_value(c, {"mesh.backlash_um", "50"});
  EXPECT_EQ(c.mesh.backlash_um, 50.0);
  EXPECT_EQ(c.name, "mine");
  EXPECT_NE(error_of([&] { set_case_value(c, {"mesh.backlash_um", "-1"}); }), "");
}

struct BadInput {
  std::string toml;
  std::vector<std::string> must_contain;
};

void PrintTo(const BadInput& b, std::ostream* os) { *os << b.toml; }

class CaseErrors : public ::testing::TestWithParam<BadInput> {};

TEST_P(CaseErrors, NameSourceKeyValueAndWhatIsAllowed) {
  const BadInput& p = GetParam();
  const std::string msg = error_of([&] { parse_case(p.toml, "bad.toml"); });
  ASSERT_NE(msg, "") << "no error for:\n" << p.toml;
  for (const std::string& s : p.must_contain) EXPECT_NE(msg.find(s), std::string::npos) << msg;
}

INSTANTIATE_TEST_SUITE_P(
    Case, CaseErrors,
    ::testing::Values(
        BadInput{"[mesh]\nbacklash_um = -5\n",
                 {"bad.toml:2", "mesh.backlash_um", "-5", "at least 0.001 um"}},
        BadInput{"[mesh]\nbacklashum = 5\n",
                 {"bad.toml:2", "unknown key", "mesh.backlashum", "backlash_um"}},
        // A slip of the keyboard is answered with the key it nearly is.
        BadInput{"[mesh]\nbacklash_mu = 5\n",
                 {"bad.toml:2", "unknown key 'mesh.backlash_mu' (did you mean 'backlash_um'?)"}},
        BadInput{"[gears]\nteeth = [1, 2]\n",
                 {"bad.toml:1", "unknown key 'gears' (did you mean 'gear'?)"}},
        BadInput{"[model]\nform = \"train\"\n[train]\nreference_sped_hz = 5\n",
                 {"bad.toml:4",
                  "unknown key 'train.reference_sped_hz' (did you mean "
                  "'reference_speed_hz'?)"}},
        BadInput{"[model]\nform = \"train\"\n[train]\nreference_speed_hz = 5\n[[train.body]]\n"
                 "name = \"a\"\ninertia_kgm2 = 1\n",
                 {"bad.toml:7", "(did you mean 'inertia_kg_m2'?)"}},
        BadInput{"[mesh]\nbacklash_um = \"big\"\n",
                 {"bad.toml:2", "mesh.backlash_um", "\"big\"", "a number"}},
        BadInput{"[mesh]\nbacklash_um = nan\n", {"bad.toml:2", "mesh.backlash_um", "nan"}},
        BadInput{"[gear]\ninertia_kg_m2 = [0.01, 0]\n",
                 {"bad.toml:2", "gear.inertia_kg_m2[1]", "> 0"}},
        BadInput{"[gear]\nteeth = [56.5, 56]\n", {"bad.toml:2", "gear.teeth", "whole numbers"}},
        BadInput{"[gear]\nteeth = [3, 56]\n", {"bad.toml:2", "gear.teeth[0]", "5 to 10000"}},
        BadInput{"[solver]\nduration_s = 0.01\ntime_step_s = 0.1\n",
                 {"bad.toml:3", "solver.time_step_s", "0.1", "smaller than solver.duration_s"}},
        BadInput{"[solver]\nmethod = \"euler\"\n",
                 {"bad.toml:2", "solver.method", "\"euler\"", "\"newmark\" | \"dopri5\""}},
        BadInput{"[mesh]\nstiffness_harmonics = [[0.6, 0], [0.5, 0]]\n",
                 {"bad.toml:2", "mesh.stiffness_harmonics", "sum is < 1"}},
        BadInput{"[mesh]\nstiffness_harmonics = [0.1, 0]\n",
                 {"bad.toml:2", "mesh.stiffness_harmonics", "[ratio k_ai/k_m, phase_deg]"}},
        BadInput{"[mesh]\ndamping_ratio = 1.5\n", {"mesh.damping_ratio", "1.5", "[0, 1)"}},
        BadInput{"[speed]\nshaft_frequency_hz = 0\n", {"speed.shaft_frequency_hz", "> 0 Hz"}},
        BadInput{"[mesh\nbacklash_um = 1\n", {"bad.toml:1", "not valid TOML"}},
        BadInput{"mesh = 3\n", {"bad.toml:1", "'mesh'", "must be a table"}}));

TEST(Case, OverrideErrorsNameTheOverride) {
  std::string msg =
      error_of([] { load_case(std::nullopt, {parse_override("mesh.backlash_um=-1")}); });
  EXPECT_NE(msg.find("--set mesh.backlash_um=-1"), std::string::npos) << msg;
  EXPECT_NE(msg.find("at least 0.001 um"), std::string::npos) << msg;

  msg = error_of([] { load_case(std::nullopt, {parse_override("speed.rpm=100")}); });
  EXPECT_NE(msg.find("--set speed.rpm=100"), std::string::npos) << msg;
  EXPECT_NE(msg.find("unknown key 'speed.rpm'"), std::string::npos) << msg;

  msg = error_of([] { load_case(std::nullopt, {parse_override("mesh.tension=[clip")}); });
  EXPECT_NE(msg.find("not a valid key and TOML value"), std::string::npos) << msg;
  // A bare word is text; a bare word that is no choice says which are.
  EXPECT_EQ(load_case(std::nullopt, {parse_override("mesh.tension=clip")}).mesh.tension,
            geardyn::TensionRule::kClip);
  EXPECT_EQ(load_case(std::nullopt, {parse_override("solver.method=dopri5")}).solver.method,
            geardyn::Method::kDopri5);
  msg = error_of([] { load_case(std::nullopt, {parse_override("solver.method=rk4")}); });
  EXPECT_NE(msg.find("solver.method"), std::string::npos) << msg;
  EXPECT_NE(msg.find("exact"), std::string::npos) << msg;
  // true and inf stay TOML's values: a boolean is no number.
  msg = error_of([] { load_case(std::nullopt, {parse_override("mesh.backlash_um=true")}); });
  EXPECT_NE(msg.find("mesh.backlash_um"), std::string::npos) << msg;

  msg = error_of([] { parse_override("speed.shaft_frequency_hz"); });
  EXPECT_NE(msg.find("key=value"), std::string::npos) << msg;
}

TEST(Case, MissingFileIsAnInputError) {
  const std::string msg = error_of([] { load_case(std::filesystem::path("no/such/case.toml")); });
  EXPECT_NE(msg.find("no/such/case.toml"), std::string::npos) << msg;
  EXPECT_NE(msg.find("cannot read"), std::string::npos) << msg;
}

TEST(Case, ValidateReportsCasesBuiltInCode) {
  Case c;
  EXPECT_EQ(validate(c), "");
  c.solver.final_fraction = 1.0;
  EXPECT_NE(validate(c).find("solver.final_fraction"), std::string::npos);
}

}  // namespace
}  // namespace geardyn

namespace {

TEST(Case, AnArrayElementIsSetByItsIndex) {
  geardyn::Case c;
  c.model.stiffness_harmonics = {{0.1, 0.0}, {0.05, 90.0}};
  geardyn::set_case_value(c, {"model.stiffness_harmonics[1][0]", "0.07"});
  EXPECT_EQ(c.model.stiffness_harmonics[1].ratio, 0.07);
  EXPECT_EQ(c.model.stiffness_harmonics[1].phase_deg, 90.0);
  EXPECT_EQ(c.model.stiffness_harmonics[0].ratio, 0.1);
  geardyn::set_case_value(c, {"model.stiffness_harmonics[0]", "[0.3, 45]"});
  EXPECT_EQ(c.model.stiffness_harmonics[0].ratio, 0.3);
  EXPECT_EQ(c.model.stiffness_harmonics[0].phase_deg, 45.0);
  // Out of range, not an array, a bad index, a value out of its range: each says so.
  const std::pair<const char*, const char*> bad[] = {
      {"model.stiffness_harmonics[2][0]", "index 2 is out of range: the array has 2 elements"},
      {"model.omega[0]", "model.omega is not an array set in this case"},
      {"model.stiffness_harmonics[x]", "an element is addressed as key[i]"},
      {"model.stiffness_harmonics[0][0]", "model.stiffness_harmonics"}};
  const char* values[] = {"0.1", "0.1", "0.1", "-1"};
  for (std::size_t i = 0; i < 4; ++i) {
    geardyn::Case d = c;
    try {
      geardyn::set_case_value(d, {bad[i].first, values[i]});
      ADD_FAILURE() << bad[i].first << " accepted";
    } catch (const geardyn::InputError& e) {
      EXPECT_NE(std::string(e.what()).find(bad[i].second), std::string::npos) << e.what();
    }
  }
}

}  // namespace

namespace {

TEST(Case, AKeyWrittenThroughAnArrayNamesTheElementsAddress) {
  // `--set train.torque.0.mean_nm=...` reads in TOML as a table where the case has its array
  // of tables [[train.torque]]: refused with the address that sets it, which does.
  const std::filesystem::path reducer = geardyn::kCases / "two_stage_reducer.toml";
  const std::pair<const char*, const char*> bad[] = {
      {"train.torque.0.mean_nm", "write train.torque[0].mean_nm"},
      {"train.torque.mean_nm", "write train.torque[0].mean_nm"},
      {"train.mesh.1.backlash_um", "write train.mesh[1].backlash_um"}};
  for (const auto& [key, address] : bad) {
    try {
      (void)geardyn::load_case(reducer, {{key, "160"}});
      ADD_FAILURE() << key << " accepted";
    } catch (const geardyn::InputError& e) {
      const std::string what = e.what();
      EXPECT_NE(what.find(std::string("--set ") + key + "=160"), std::string::npos) << what;
      EXPECT_NE(what.find("of tables ([["), std::string::npos) << what;
      EXPECT_NE(what.find(address), std::string::npos) << what;
    }
  }
  const geardyn::Case c = geardyn::load_case(reducer, {{"train.torque[0].mean_nm", "160"}});
  ASSERT_TRUE(c.train);
  EXPECT_EQ(c.train->torques.at(0).mean_nm, 160.0);
  // A key that reaches no array is TOML's as before.
  EXPECT_EQ(
      geardyn::load_case(reducer, {{"train.reference_speed_hz", "40"}}).train->reference_speed_hz,
      40.0);
}

}  // namespace
