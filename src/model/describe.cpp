#include "geardyn/describe.hpp"

#include <fmt/format.h>

#include <cmath>
#include <nlohmann/json.hpp>
#include <numbers>
#include <optional>

#include "geardyn/plausibility.hpp"
#include "geardyn/train.hpp"
#include "geardyn/train_case.hpp"
#include "geardyn/train_statics.hpp"

namespace geardyn {
namespace {

using Json = nlohmann::ordered_json;

// A frame's name: "ground", or its carrier's.
std::string frame_name(const train::Assembled& a, int f) {
  if (f == train::kGroundFrame) return "ground";
  if (f == train::kMixedFrame) return "(two)";
  return a.train().bodies[static_cast<std::size_t>(f)].name;
}

Json describe(const Case& c) {
  const train::Assembled a = assembled_train(c);
  const train::Train& t = a.train();
  Json j;
  j["reference"] = t.reference;
  j["reference_speed_hz"] = t.reference_speed_hz;
  const std::optional<Eigen::VectorXd> rest = static_state(a);
  const std::vector<double> forces =
      rest ? static_mesh_forces_n(a, *rest) : std::vector<double>(t.meshes.size(), NAN);
  Json bodies = Json::array();
  for (int i = 0; i < a.body_count(); ++i) {
    const train::Body& b = t.bodies[static_cast<std::size_t>(i)];
    Json x = {{"name", b.name},
              {"speed_hz", a.body_speed_hz(i)},
              {"speed_rpm", 60 * a.body_speed_hz(i)},
              {"frame", frame_name(a, a.frame(i))},
              {"inertia_kg_m2", b.inertia_kg_m2}};
    if (b.planar) x["mass_kg"] = b.mass_kg;
    bodies.push_back(x);
  }
  j["bodies"] = bodies;
  Json meshes = Json::array();
  for (int m = 0; m < static_cast<int>(t.meshes.size()); ++m) {
    const train::Mesh& x = t.meshes[static_cast<std::size_t>(m)];
    Json y = {{"name", x.name},
              {"driving", x.driving},
              {"driven", x.driven},
              {"frame", frame_name(a, a.mesh_frame(m))},
              {"mesh_frequency_hz", a.mesh_frequency_hz(m)},
              {"mean_stiffness_n_per_m", x.mean_stiffness_n_per_m},
              {"damping_n_s_per_m", x.damping_n_s_per_m},
              {"backlash_m", x.backlash_m}};
    const double f = forces[static_cast<std::size_t>(m)];
    y["static_force_n"] = std::isfinite(f) ? Json(f) : Json(nullptr);
    meshes.push_back(y);
  }
  j["meshes"] = meshes;
  Json shafts = Json::array();
  for (const train::Shaft& s : t.shafts)
    shafts.push_back({{"name", s.name},
                      {"from", s.a},
                      {"to", s.b},
                      {"stiffness_n_m_per_rad", s.stiffness_n_m_per_rad},
                      {"damping_n_m_s_per_rad", s.damping_n_m_s_per_rad}});
  j["shafts"] = shafts;
  Json bearings = Json::array();
  for (const train::Bearing& b : t.bearings) {
    Json x = {{"name", b.name},
              {"body", b.body},
              {"stiffness_n_per_m", b.stiffness_n_per_m},
              {"damping_n_s_per_m", b.damping_n_s_per_m}};
    if (!b.on.empty()) {
      x["on"] = b.on;
      x["pin_radius_m"] = b.pin_radius_m;
    }
    bearings.push_back(x);
  }
  j["bearings"] = bearings;
  // Each joint read as a part (an element's: a clutch damper): its edges, each stage's stiffness
  // and damping, and the stage the static state loads it in (its index among them).
  Json joints = Json::array();
  for (std::size_t k = 0; k < a.joints().size(); ++k) {
    const train::Joint& x = a.joints()[k];
    if (!x.read) continue;
    Json stiffness = Json::array(), damping = Json::array();
    for (const train::JointStage& g : x.stages) {
      stiffness.push_back(g.stiffness);
      damping.push_back(g.damping);
    }
    joints.push_back({{"name", x.name},
                      {"edges", x.edges},
                      {"stiffness", stiffness},
                      {"damping", damping},
                      {"static_stage", a.operating_stages()[k]}});
  }
  j["joints"] = joints;
  // Each link (an element's joint of one stage that nothing reads: a drag): its element, its
  // stiffness, damping and constant force f (it acts as -row^T (k x + f + c x')).
  Json links = Json::array();
  for (const train::Joint& x : a.links())
    links.push_back({{"name", x.name},
                     {"element", x.label},
                     {"stiffness", x.stages[0].stiffness},
                     {"damping", x.stages[0].damping},
                     {"constant_force", x.stages[0].force_at_zero}});
  j["links"] = links;
  Json torques = Json::array();
  for (const train::Torque& q : t.torques)
    torques.push_back({{"name", q.name}, {"body", q.body}, {"mean_nm", q.mean_nm}});
  j["torques"] = torques;
  j["warnings"] = train_plausibility(c);
  return j;
}

}  // namespace

std::string describe_json(const Case& c) { return describe(c).dump(2); }

std::string describe_text(const Case& c) {
  const Json j = describe(c);
  std::string out =
      fmt::format("{} as assembled: reference '{}' at {:.6g} Hz ({:.6g} rpm)\n", c.name,
                  j["reference"].get<std::string>(), j["reference_speed_hz"].get<double>(),
                  60 * j["reference_speed_hz"].get<double>());
  out += fmt::format("  {:<16} {:>12} {:>12} {:>14} {:>10}\n", "body", "speed rpm", "frame",
                     "inertia kg m2", "mass kg");
  for (const Json& b : j["bodies"])
    out += fmt::format("  {:<16} {:>12.6g} {:>12} {:>14.6g} {:>10}\n", b["name"].get<std::string>(),
                       b["speed_rpm"].get<double>(), b["frame"].get<std::string>(),
                       b["inertia_kg_m2"].get<double>(),
                       b.contains("mass_kg") ? fmt::format("{:.6g}", b["mass_kg"].get<double>())
                                             : std::string("-"));
  out += fmt::format("  {:<16} {:>12} {:>12} {:>14} {:>12} {:>10} {:>12}\n", "mesh", "Hz", "frame",
                     "k_m N/m", "c N s/m", "b um", "static N");
  for (const Json& m : j["meshes"])
    out += fmt::format("  {:<16} {:>12.6g} {:>12} {:>14.6g} {:>12.6g} {:>10.6g} {:>12}\n",
                       m["name"].get<std::string>(), m["mesh_frequency_hz"].get<double>(),
                       m["frame"].get<std::string>(), m["mean_stiffness_n_per_m"].get<double>(),
                       m["damping_n_s_per_m"].get<double>(), 1e6 * m["backlash_m"].get<double>(),
                       m["static_force_n"].is_null()
                           ? std::string("none")
                           : fmt::format("{:.6g}", m["static_force_n"].get<double>()));
  if (!j["shafts"].empty())
    out += fmt::format("  {:<16} {:>14} {:>14}\n", "shaft", "k N m/rad", "c N m s/rad");
  for (const Json& s : j["shafts"])
    out += fmt::format("  {:<16} {:>14.6g} {:>14.6g}\n", s["name"].get<std::string>(),
                       s["stiffness_n_m_per_rad"].get<double>(),
                       s["damping_n_m_s_per_rad"].get<double>());
  if (!j["bearings"].empty())
    out += fmt::format("  {:<16} {:>14} {:>14} {:>14}\n", "bearing", "k N/m", "c N s/m",
                       "pin radius mm");
  for (const Json& b : j["bearings"])
    out += fmt::format("  {:<16} {:>14.6g} {:>14.6g} {:>14}\n", b["name"].get<std::string>(),
                       b["stiffness_n_per_m"].get<double>(), b["damping_n_s_per_m"].get<double>(),
                       b.contains("pin_radius_m")
                           ? fmt::format("{:.6g}", 1e3 * b["pin_radius_m"].get<double>())
                           : std::string("-"));
  // A joint's stages from its most negative x up, each stiffness with the edge between them; the
  // stage the static state loads marked.
  for (const Json& x : j["joints"]) {
    const std::vector<double> k = x["stiffness"], edges = x["edges"];
    std::string stages;
    const int loaded = x["static_stage"].get<int>();
    for (std::size_t s = 0; s < k.size(); ++s)
      stages += fmt::format("{}{:.6g}{}", s == 0 ? "" : fmt::format(" |{:.6g}| ", edges[s - 1]),
                            k[s], static_cast<int>(s) == loaded ? "*" : "");
    out += fmt::format("  joint {:<10} stiffness by stage, |edge| between (* static): {}\n",
                       x["name"].get<std::string>(), stages);
  }
  for (const Json& x : j["links"])
    out += fmt::format(
        "  {}: stiffness {:.6g}, damping {:.6g}, constant force {:.6g} (each resisting "
        "its deformation)\n",
        x["element"].get<std::string>(), x["stiffness"].get<double>(), x["damping"].get<double>(),
        x["constant_force"].get<double>());
  for (const Json& q : j["torques"])
    out += fmt::format("  torque {:<9} on {}: mean {:.6g} N m\n", q["name"].get<std::string>(),
                       q["body"].get<std::string>(), q["mean_nm"].get<double>());
  for (const Json& w : j["warnings"]) out += fmt::format("  warning: {}\n", w.get<std::string>());
  return out;
}

}  // namespace geardyn
