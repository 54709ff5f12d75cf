// The drag (drag.hpp), a train element in one file: its constant torque against the balance of
// power and the mesh force it loads, its viscous part as the damping of the free rotation (and
// nothing else), and its refusals.
#include "geardyn/drag.hpp"

#include <fmt/format.h>
#include <gtest/gtest.h>

#include <Eigen/Core>
#include <cmath>
#include <fstream>
#include <nlohmann/json.hpp>
#include <sstream>
#include <string>

#include "geardyn/case.hpp"
#include "geardyn/describe.hpp"
#include "geardyn/train.hpp"
#include "geardyn/train_case.hpp"
#include "geardyn/train_run.hpp"
#include "geardyn/train_statics.hpp"
#include "test_support.hpp"

namespace geardyn {
namespace {

// Two spur gears, the input (30 teeth) driven by a torque that balances the drag on the output
// (45 teeth): `drag` is the [[train.drag]] table's keys.
std::string gears(const std::string& drag) {
  return fmt::format(R"(
[model]
form = "train"
[train]
reference = "input"
reference_speed_hz = 25
{}
[[train.torque]]
name = "drive"
body = "input"
balances = true
[[train.drag]]
name = "oil"
body = "output"
{}
)",
                     geardyn::testing::spur_stage_toml(0.05), drag);
}

std::string shipped(const char* name) {
  std::ifstream in(std::string(GEARDYN_SOURCE_DIR) + "/cases/" + name);
  std::ostringstream text;
  text << in.rdbuf();
  return text.str();
}

TEST(Drag, ItsConstantTorqueIsWhatTheDriveBalancesAndTheMeshCarries) {
  // The drive's mean is the drag's through the ratio (its power: T_in w_in = T_c w_out), and
  // the static mesh force is the drag over the output's base radius, at the static state and
  // in a run's reading; a drag acts against the output's rotation, so the input drives.
  constexpr double kDrag = 12.5;
  const Case c = parse_case(gears(fmt::format("constant_nm = {}", kDrag)), "gears.toml");
  const train::Assembled a = assembled_train(c);
  ASSERT_EQ(a.train().torques.size(), 1U);
  EXPECT_NEAR(a.train().torques[0].mean_nm, kDrag * 30.0 / 45.0, 1e-12 * kDrag);
  EXPECT_NEAR(a.mean_power_nm(), 0.0, 1e-12 * kDrag);
  const double r_output = a.train().meshes[0].base_radius_driven_m;
  const std::optional<Eigen::VectorXd> y = static_state(a);
  ASSERT_TRUE(y);
  const double k = a.train().meshes[0].mean_stiffness_n_per_m;
  const double b = a.train().meshes[0].backlash_m;
  EXPECT_NEAR(k * (a.mesh_vector(0).dot(*y) - b), kDrag / r_output, 1e-9 * kDrag / r_output);
  Case short_run = c;
  set_case_value(short_run, {"solver.duration_s", "0.01"});
  const TrainRunResult r = run_train(short_run, TrainRunOptions{});
  ASSERT_EQ(r.meshes.size(), 1U);
  ASSERT_TRUE(r.meshes[0].static_force_n);
  EXPECT_NEAR(*r.meshes[0].static_force_n, kDrag / r_output, 1e-9 * kDrag / r_output);
  // A drag is a link (one stage, not read): no contact part, no reading.
  EXPECT_EQ(a.links().size(), 1U);
  EXPECT_TRUE(a.joints().empty());
  EXPECT_TRUE(r.joints.empty());
  // `geardyn describe` shows it among the links, its constant force the drag's.
  const nlohmann::json d = nlohmann::json::parse(describe_json(c));
  ASSERT_EQ(d["links"].size(), 1U);
  EXPECT_EQ(d["links"][0]["element"], "drag 'oil'");
  EXPECT_DOUBLE_EQ(d["links"][0]["constant_force"].get<double>(), kDrag);
  EXPECT_NE(describe_text(c).find("drag 'oil': stiffness 0, damping 0, constant force 12.5"),
            std::string::npos)
      << describe_text(c);
}

TEST(Drag, ItsViscousPartAloneDampsTheFreeRotation) {
  // A viscous drag damps the train's rigid rotation (C r != 0), a constant one does not, and a
  // clutch damper's damping between two bodies the rotation turns alike does not either.
  const auto damps = [](const std::string& text) {
    return assembled_train(parse_case(text, "t.toml")).damps_rigid_motions();
  };
  EXPECT_TRUE(damps(gears("viscous_n_m_s_per_rad = 0.01")));
  EXPECT_FALSE(damps(gears("constant_nm = 3")));
  std::string damped = shipped("loose_gear_damper.toml");
  EXPECT_FALSE(damps(damped));  // the driver's speed is prescribed: no rigid motion
  // Without the prescription the driveline turns freely: the damper's damping is along no rigid
  // motion, a viscous drag is.
  std::string free = gears("constant_nm = 1") + R"(
[[train.body]]
name = "flywheel"
inertia_kg_m2 = 0.1
[[train.damper]]
name = "clutch"
from = "flywheel"
to = "input"
stiffness_n_m_per_rad = 600
damping_n_m_s_per_rad = 2
)";
  EXPECT_FALSE(damps(free));
  free.replace(free.find("constant_nm = 1"), 15, "viscous_n_m_s_per_rad = 1");
  EXPECT_TRUE(damps(free));
}

TEST(Drag, RefusesAPrescribedBodyAndAConstantDragOnABodyAtRest) {
  using geardyn::testing::error_of;
  // The loose gear's driver has its speed prescribed.
  std::string loose = shipped("loose_gear_rattle.toml");
  const std::string on = "body = \"loose\"\nconstant_nm";
  ASSERT_NE(loose.find(on), std::string::npos);
  loose.replace(loose.find(on), on.size(), "body = \"input\"\nconstant_nm");
  const std::string prescribed =
      error_of([&] { assembled_train(parse_case(loose, "loose.toml")); });
  EXPECT_NE(prescribed.find("its speed is prescribed, so no drag acts on it"), std::string::npos)
      << prescribed;
  // The planetary set's ring is held: a constant drag has nothing to oppose, a viscous one is
  // taken (it acts on the ring's small motion).
  const std::string ring = shipped("planetary_set.toml") +
                           "\n[[train.drag]]\nname = \"seal\"\nbody = \"ring\"\nconstant_nm = 1\n";
  const std::string at_rest = error_of([&] { assembled_train(parse_case(ring, "set.toml")); });
  EXPECT_NE(at_rest.find("drag 'seal': body = \"ring\" is at rest: a constant drag has no "
                         "rotation to oppose"),
            std::string::npos)
      << at_rest;
  const std::string viscous =
      shipped("planetary_set.toml") +
      "\n[[train.drag]]\nname = \"seal\"\nbody = \"ring\"\nviscous_n_m_s_per_rad = 1\n";
  EXPECT_NO_THROW(assembled_train(parse_case(viscous, "set.toml")));
}

}  // namespace
}  // namespace geardyn
