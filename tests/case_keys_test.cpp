// The table of case keys: every bound it declares is the bound the reader applies (just inside
// is read, just outside is refused naming the key), every key survives case.toml, and a study
// takes exactly the keys it marks.
#include "geardyn/case_keys.hpp"

#include <fmt/format.h>
#include <gtest/gtest.h>

#include <cmath>
#include <filesystem>
#include <fstream>
#include <regex>
#include <sstream>
#include <string>
#include <vector>

#include "geardyn/run.hpp"
#include "geardyn/stiffness.hpp"
#include "test_support.hpp"

namespace geardyn {
namespace {

using geardyn::testing::error_of;

// A TOML value that puts `x` where the key's bound applies: the number, a pair of it, or one
// harmonic with it as the ratio.
std::string value_for(const CaseKey& k, double x) {
  const std::string n =
      k.integer() ? fmt::format("{}", static_cast<long long>(x)) : fmt::format("{:.17g}", x);
  if (std::holds_alternative<PairField>(k.field) ||
      std::holds_alternative<OptionalPairField>(k.field) ||
      std::holds_alternative<IntegerPairField>(k.field))
    return fmt::format("[{0}, {0}]", n);
  if (std::holds_alternative<HarmonicsField>(k.field) ||
      std::holds_alternative<ErrorHarmonicsField>(k.field))
    return fmt::format("[[{}, 0]]", n);
  return n;
}

// The overrides that set key k to x (harmonics of the mesh need their source).
std::vector<Override> set_to(const CaseKey& k, double x) {
  std::vector<Override> o{{std::string(k.name), value_for(k, x)}};
  if (k.name == "mesh.stiffness_harmonics") o.push_back({"mesh.stiffness_source", "harmonics"});
  return o;
}

bool numeric(const CaseKey& k) {
  return !std::holds_alternative<TextField>(k.field) &&
         !std::holds_alternative<ChoiceField>(k.field);
}

TEST(CaseKeys, EveryBoundIsTheReadersOwn) {
  int ends = 0;
  for (const CaseKey& k : case_keys()) {
    if (!numeric(k)) continue;
    const Range& r = k.range;
    for (const bool low : {true, false}) {
      const double end = low ? r.lo : r.hi;
      if (!std::isfinite(end)) continue;
      ++ends;
      const bool closed = low ? r.lo_closed : r.hi_closed;
      // Just outside: one unit for whole numbers, a relative 1e-9 (or 1e-12 at 0) otherwise.
      const double step = k.integer() ? 1.0 : std::max(std::abs(end) * 1e-9, 1e-12);
      const double outside = low ? end - step : end + step;
      const std::string msg = error_of([&] { (void)load_case(std::nullopt, set_to(k, outside)); });
      EXPECT_NE(msg.find(std::string(k.name)), std::string::npos) << k.name << " at " << outside;
      EXPECT_NE(msg.find("must be"), std::string::npos) << msg;
      const std::string at_end = error_of([&] { (void)load_case(std::nullopt, set_to(k, end)); });
      EXPECT_EQ(at_end.empty(), closed) << k.name << " at its end " << end << ": " << at_end;
    }
    // Not a number at all.
    if (!std::holds_alternative<HarmonicsField>(k.field) &&
        !std::holds_alternative<ErrorHarmonicsField>(k.field)) {
      const std::string nan = error_of([&] { (void)load_case(std::nullopt, set_to(k, NAN)); });
      EXPECT_FALSE(nan.empty()) << k.name << " took nan";
    }
  }
  EXPECT_GE(ends, 30);
}

TEST(CaseKeys, APerGearKeyTakesOneNumberForBoth) {
  const Case c = load_case(std::nullopt, {{"bearings.radial_stiffness_n_per_m", "2e9"},
                                          {"gear.profile_shift", "[0.1, 0.3]"}});
  EXPECT_EQ(c.bearings.radial_stiffness_n_per_m[0], 2e9);
  EXPECT_EQ(c.bearings.radial_stiffness_n_per_m[1], 2e9);
  EXPECT_EQ(c.gear.profile_shift[1], 0.3);
  const std::string bad = error_of([] {
    (void)load_case(std::nullopt, {{"gear.profile_shift", "[1, 2, 3]"}});
  });
  EXPECT_NE(bad.find("a number for both gears, or an array of two"), std::string::npos) << bad;
}

TEST(CaseKeys, MessagesSayTheBoundWithItsUnit) {
  const std::string msg = error_of([] {
    (void)load_case(std::nullopt, {{"gear.normal_module_mm", "0"}});
  });
  EXPECT_NE(msg.find("gear.normal_module_mm = 0: must be a module in (0, 100] mm"),
            std::string::npos)
      << msg;
  const std::string b = error_of([] {
    (void)load_case(std::nullopt, {{"mesh.backlash_um", "-5"}});
  });
  EXPECT_NE(b.find("must be a finite half backlash b of at least 0.001 um"), std::string::npos)
      << b;
  const std::string z = error_of([] {
    (void)load_case(std::nullopt, {{"gear.teeth", "[56, 4]"}});
  });
  EXPECT_NE(z.find("gear.teeth[1] = 4: must be a whole number of teeth from 5 to 10000"),
            std::string::npos)
      << z;
}

TEST(CaseKeys, EveryKeyIsWrittenAndReadBack) {
  Case c;
  c.gear.inertia_kg_m2 = std::array<double, 2>{0.01, 0.02};
  c.load.load_torque_nm = 40.0;
  c.description = "all \"keys\"";
  c.origins["solver.method"] = "the test";  // a method not given is not written (below)
  const std::string text = to_toml(c);
  for (const CaseKey& k : case_keys()) {
    const std::string line = fmt::format("\n{} = {}\n", k.leaf(), k.value_text(c));
    EXPECT_NE(("\n" + text).find(line), std::string::npos) << k.name << "\n" << text;
  }
  EXPECT_EQ(to_toml(parse_case(text, "all")), text);
  // A method left to the default is chosen per case: written, it would read as asked for.
  EXPECT_EQ(to_toml(Case{}).find("\nmethod = "), std::string::npos);
  // An optional key left absent is not written.
  EXPECT_EQ(to_toml(Case{}).find("\ninertia_kg_m2"), std::string::npos);
  EXPECT_NE(to_toml(c).find("\ninertia_kg_m2"), std::string::npos);
}

// The text of a section of a case file ("[mesh]" to the next section).
std::string section_text(const std::string& file, std::string_view section) {
  std::ifstream in(std::filesystem::path(GEARDYN_SOURCE_DIR) / "cases" / file);
  std::stringstream text;
  text << in.rdbuf();
  const std::string all = text.str();
  const std::size_t at = all.find(fmt::format("[{}]", section));
  if (at == std::string::npos) return "";
  return all.substr(at, all.find("\n[", at + 1) - at);
}

TEST(CaseKeys, TheShippedCasesWriteEveryKeyOut) {
  // The shipped cases together show every key (set, or in a comment where it is optional or
  // needs another source): cases/park2010.toml the gear pair's, cases/kahraman_singh.toml the
  // non-dimensional form's [model], cases/park2010_coupled.toml the coupled model's.
  const std::vector<std::string> files = {"park2010.toml", "kahraman_singh.toml",
                                          "park2010_coupled.toml"};
  for (const CaseKey& k : case_keys()) {
    if (k.section().empty()) continue;
    bool shown = false;
    for (const std::string& file : files) {
      const std::string body = section_text(file, k.section());
      shown = shown || body.find(fmt::format("\n{} =", k.leaf())) != std::string::npos ||
              body.find(fmt::format("\n# {} =", k.leaf())) != std::string::npos;
    }
    EXPECT_TRUE(shown) << k.name;
  }
  for (const std::string& file : files)
    EXPECT_NO_THROW((void)load_case(std::filesystem::path(GEARDYN_SOURCE_DIR) / "cases" / file))
        << file;
  EXPECT_EQ(load_case(std::filesystem::path(GEARDYN_SOURCE_DIR) / "cases" / "kahraman_singh.toml")
                .model.form,
            ModelForm::kNondimensional);
}

TEST(CaseKeys, AStudyTakesTheRealNumbersTheModelReads) {
  EXPECT_EQ(check_sweepable("model.omega"), "");
  EXPECT_EQ(check_sweepable("model.stiffness_harmonics[0][0]"), "");
  EXPECT_EQ(check_sweepable("gear.outside_diameter_mm[1]"), "");
  EXPECT_NE(check_sweepable("speed.rpm").find("speed.rpm: unknown key"), std::string::npos);
  for (const char* key : {"solver.method", "solver.duration_s", "mesh.harmonics_kept", "gear.teeth",
                          "mesh.stiffness_table", "description"})
    EXPECT_NE(check_sweepable(key).find("not a real number the model reads"), std::string::npos)
        << key;
  // A train's: its reference speed, an element's real number, one entry of its harmonics.
  for (const char* key :
       {"train.reference_speed_hz", "train.mesh[1].backlash_um",
        "train.speed[0].acceleration_harmonics[0][0]", "train.torque[2].harmonics[1][1]",
        "train.mesh[0].stiffness_harmonics[0][1]"})
    EXPECT_EQ(check_sweepable(key), "") << key;
  for (const char* key : {"train.speed[0].acceleration_harmonics", "train.body[0].name",
                          "train.body[0].teeth", "train.body[0].name[0][0]"})
    EXPECT_NE(check_sweepable(key).find("not a real number the model reads"), std::string::npos)
        << key;
  for (const char* key :
       {"train.speed[0].acceleration_harmonics[0]",
        "train.speed[0].acceleration_harmonics[0][0][0]",
        "train.speed[0].acceleration_harmonics[a][0]", "train.speed[0].acceleration_harmonics[0][]",
        "train.mesh[0].shape[0][0]"})
    EXPECT_NE(check_sweepable(key).find("unknown key"), std::string::npos) << key;
  // Every sweepable key is a number, a pair or harmonics.
  for (const CaseKey& k : case_keys())
    if (k.sweepable) EXPECT_TRUE(numeric(k) && !k.integer()) << k.name;
}

// The key's value in `c` moved by 10 % (a zero, or an absent value, to 1), as TOML.
std::string moved(const CaseKey& k, Case& c) {
  const auto move = [](double v) { return fmt::format("{:.17g}", v == 0 ? 1.0 : 1.1 * v); };
  if (const auto* f = std::get_if<NumberField>(&k.field)) return move((*f)(c));
  if (const auto* f = std::get_if<OptionalNumberField>(&k.field)) return move((*f)(c).value_or(0));
  if (const auto* f = std::get_if<PairField>(&k.field))
    return fmt::format("[{}, {}]", move((*f)(c)[0]), move((*f)(c)[1]));
  if (const auto* f = std::get_if<OptionalPairField>(&k.field)) {
    const std::array<double, 2> v = (*f)(c).value_or(std::array<double, 2>{0, 0});
    return fmt::format("[{}, {}]", move(v[0]), move(v[1]));
  }
  if (std::holds_alternative<ErrorHarmonicsField>(k.field)) return "[[1.0, 0]]";
  ADD_FAILURE() << k.name << ": no way to move it";
  return "";
}

TEST(CaseKeys, SettingANumberInPlaceIsDecodingTheCaseAgain) {
  // set_case_value sets a study's number within its range in place; decoding the case again
  // with the override (its slow path) must give the same case, for every such key of every
  // form, each element of a pair alone, and the origin names the override.
  for (const ModelForm form :
       {ModelForm::kGearPair, ModelForm::kNondimensional, ModelForm::kCoupled}) {
    Case base;
    base.model.form = form;
    int set = 0;
    for (const CaseKey& k : case_keys()) {
      if (!k.sweepable) continue;
      const bool pair = std::holds_alternative<PairField>(k.field);
      if (!pair && !std::holds_alternative<NumberField>(k.field) &&
          !std::holds_alternative<OptionalNumberField>(k.field))
        continue;
      Case probe = base;
      const std::string value = moved(k, probe);
      std::vector<Override> overrides;
      if (pair) {
        const std::string inner = value.substr(1, value.size() - 2);
        const std::size_t comma = inner.find(',');
        overrides.push_back({std::string(k.name) + "[0]", inner.substr(0, comma), "here"});
        overrides.push_back({std::string(k.name) + "[1]", inner.substr(comma + 2), "here"});
      } else {
        overrides.push_back({std::string(k.name), value, "here"});
      }
      for (const Override& o : overrides) {
        if (!k.range.contains(std::stod(o.value))) continue;  // the slow path's message then
        Case fast = base;
        const std::string refused =
            testing::error_of([&] { (void)parse_case(to_toml(base), "(case)", {o}); });
        if (!refused.empty()) {
          // A rule tying keys together: the same message, but the other keys cited where they
          // came from (base's are all defaults), not at their places in the text read again.
          EXPECT_EQ(testing::error_of([&] { set_case_value(fast, o); }),
                    std::regex_replace(refused, std::regex(R"( from \(case\):[0-9]+:[0-9]+)"),
                                       ": default value"))
              << o.key;
          continue;
        }
        set_case_value(fast, o);
        const Case slow = parse_case(to_toml(base), "(case)", {o});
        EXPECT_EQ(to_toml(fast), to_toml(slow)) << o.key;
        EXPECT_EQ(fast.origins.at(std::string(k.name)), "here") << o.key;
        ++set;
      }
    }
    EXPECT_GE(set, 30);
  }
}

TEST(CaseKeys, AKeyNotMarkedForTheStiffnessLeavesTheCurveAsItIs) {
  // A sweep computes the curve once when its key is not marked changes_stiffness: every such key
  // a study may vary, moved by 10 %, must leave the energy method's curve (unscaled: mean 0) and
  // its kept harmonics exactly as they were. The marked keys that shape the teeth move it.
  Case base;
  base.mesh.mean_stiffness_n_per_m = 0;
  base.model.form = ModelForm::kCoupled;  // the form every key applies to (shafts, bearings)
  base.load.load_torque_nm = 49.5;        // so that T2's fluctuation may move
  // Computed afresh (mesh_stiffness would give a curve it computed before for the same keys).
  const auto curve = [](const Case& c) {
    return fourier_harmonics(energy_method_cycle(c, case_geometry(c)), c.mesh.harmonics_kept);
  };
  const StiffnessFourier k0 = curve(base);
  int unmarked = 0;
  for (const CaseKey& k : case_keys()) {
    if (!k.sweepable || k.changes_stiffness || k.section() == "model") continue;
    Case c = base;
    set_case_value(c, {std::string(k.name), moved(k, c)});
    const StiffnessFourier k1 = curve(c);
    EXPECT_EQ(k1.mean_n_per_m, k0.mean_n_per_m) << k.name;
    ASSERT_EQ(k1.harmonics.size(), k0.harmonics.size());
    for (std::size_t i = 0; i < k0.harmonics.size(); ++i)
      EXPECT_EQ(k1.harmonics[i].ratio, k0.harmonics[i].ratio) << k.name;
    ++unmarked;
  }
  EXPECT_GE(unmarked, 8);
  for (const Override& o : std::vector<Override>{{"gear.face_width_mm", "21"},
                                                 {"gear.helix_angle_deg", "21"},
                                                 {"gear.youngs_modulus_gpa", "[210, 206]"},
                                                 {"gear.bore_diameter_mm", "[60, 60]"}}) {
    Case c = base;
    set_case_value(c, o);
    EXPECT_NE(curve(c).mean_n_per_m, k0.mean_n_per_m) << o.key;
  }
}

}  // namespace
}  // namespace geardyn
