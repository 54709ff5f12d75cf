#include "geardyn/damper.hpp"

#include <fmt/format.h>

#include <numbers>
#include <utility>

#include "geardyn/input_error.hpp"
#include "geardyn/train.hpp"
#include "model/element_keys.hpp"

namespace geardyn {
namespace {

using namespace element_keys;

constexpr double kDegToRad = std::numbers::pi / 180.0;

// The drive side of the characteristic: the angles (rad) where each stage engages, ascending,
// each with the stiffness beyond it, and the stiffness from the centre to the first.
struct Side {
  std::vector<double> edges, beyond;
  double inner = 0;
};

class Damper final : public train::Element {
 public:
  Damper(TrainDamperData d, Side side) : d_(std::move(d)), side_(std::move(side)) {}

  std::string label() const override { return fmt::format("damper '{}'", d_.name); }
  std::vector<std::array<std::string, 2>> bodies() const override {
    return {{"from", d_.from}, {"to", d_.to}};
  }
  std::vector<std::array<std::string, 2>> couplings() const override { return {{d_.from, d_.to}}; }

  // One joint on x = theta_from - theta_to: the coast side's stages (mirrored), the centre's,
  // the drive side's.
  std::vector<train::Joint> joints(const train::Assembled& a) const override {
    train::Joint j;
    j.name = d_.name;
    j.row = Eigen::RowVectorXd::Zero(a.size());
    j.row(a.index(d_.from)) += 1;
    if (d_.to != train::kGround) j.row(a.index(d_.to)) -= 1;
    const std::size_t n = side_.edges.size();
    const bool free_play = d_.free_play_deg > 0;
    // T at each edge on the drive side, each stage continuing the one before.
    std::vector<double> at_edge(n);
    double t = 0, from = 0, k = side_.inner;
    for (std::size_t i = 0; i < n; ++i) {
      t += k * (side_.edges[i] - from);
      at_edge[i] = t;
      from = side_.edges[i];
      k = side_.beyond[i];
    }
    // The damping of a stage: none in a free play without an idle spring (nothing touches).
    const auto damping = [&](bool inner) {
      return inner && free_play && d_.free_play_stiffness_n_m_per_rad == 0
                 ? 0.0
                 : d_.damping_n_m_s_per_rad;
    };
    // The coast side, from the outermost stage in: beyond -e_i, T = k_i x - (T(e_i) - k_i e_i).
    for (std::size_t i = n; i-- > 0;) {
      j.edges.push_back(-side_.edges[i]);
      j.stages.push_back(
          {side_.beyond[i], -(at_edge[i] - side_.beyond[i] * side_.edges[i]), damping(false)});
    }
    j.rest = static_cast<int>(n);
    j.stages.push_back({side_.inner, 0.0, damping(true)});
    for (std::size_t i = 0; i < n; ++i) {
      j.edges.push_back(side_.edges[i]);
      j.stages.push_back(
          {side_.beyond[i], at_edge[i] - side_.beyond[i] * side_.edges[i], damping(false)});
    }
    j.scale = n > 0 ? side_.edges.front() : 1.0;
    j.read = true;
    j.stops = d_.stop_deg.has_value();
    j.force_what = "torque_nm";
    j.deformation_what = "twist_rad";
    // Until the static state places it: in stage 1 on the drive side.
    j.operating = j.rest + (free_play ? 1 : 0);
    return {j};
  }

 private:
  TrainDamperData d_;
  Side side_;
};

}  // namespace

std::shared_ptr<const train::Element> TrainDamperData::element() const {
  const std::string label = fmt::format("damper '{}'", name);
  if (from == to)
    throw InputError(
        fmt::format("{}: to = \"{}\": a damper joins two bodies (from = \"{}\")", label, to, from));
  // Each stage's angle with its stiffness, or neither.
  const auto pair = [&](const char* angle, const std::optional<double>& a, const char* stiffness,
                        const std::optional<double>& k) {
    if (a.has_value() != k.has_value())
      throw InputError(
          fmt::format("{}: {} = {}: give {} with it (a stage is an angle and a "
                      "stiffness)",
                      label, a ? angle : stiffness, a ? *a : *k, a ? stiffness : angle));
  };
  pair("stage2_deg", stage2_deg, "stage2_stiffness_n_m_per_rad", stage2_stiffness_n_m_per_rad);
  pair("stop_deg", stop_deg, "stop_stiffness_n_m_per_rad", stop_stiffness_n_m_per_rad);
  Side side;
  side.inner = free_play_deg > 0 ? free_play_stiffness_n_m_per_rad : stiffness_n_m_per_rad;
  const auto engage = [&](const char* key, double deg, double k) {
    if (!side.edges.empty() && !(deg * kDegToRad > side.edges.back()))
      throw InputError(fmt::format(
          "{}: {} = {}: a stage engages beyond the one before it (free play, stage 2, stop), "
          "here beyond {} deg",
          label, key, deg, side.edges.back() / kDegToRad));
    side.edges.push_back(deg * kDegToRad);
    side.beyond.push_back(k);
  };
  if (free_play_deg > 0) engage("free_play_deg", free_play_deg, stiffness_n_m_per_rad);
  if (free_play_deg == 0 && free_play_stiffness_n_m_per_rad != 0)
    throw InputError(
        fmt::format("{}: free_play_stiffness_n_m_per_rad = {}: there is no free "
                    "play (free_play_deg = 0)",
                    label, free_play_stiffness_n_m_per_rad));
  if (stage2_deg) engage("stage2_deg", *stage2_deg, *stage2_stiffness_n_m_per_rad);
  if (stop_deg) engage("stop_deg", *stop_deg, *stop_stiffness_n_m_per_rad);
  return std::make_shared<Damper>(*this, std::move(side));
}

const std::vector<ElementKey<TrainDamperData>>& damper_keys() {
  using D = TrainDamperData;
  static const std::vector<ElementKey<D>> keys = {
      {"name", &D::name, "", {}, false, "the damper's name"},
      {"from",
       &D::from,
       "",
       {},
       true,
       "the body on its drive side (the engine's): the twist is its rotation less to's"},
      {"to",
       &D::to,
       "",
       {},
       true,
       "the body it drives (a gearbox's input shaft), or \"ground\" to hold from"},
      {"stiffness_n_m_per_rad", &D::stiffness_n_m_per_rad, "N m/rad", above(0), true,
       "stage 1's torsional stiffness, from the end of the free play"},
      {"free_play_deg", &D::free_play_deg, "deg", closed_open(0, 180), false,
       "the twist either way from the centre within which stage 1 does not act (0: none)"},
      {"free_play_stiffness_n_m_per_rad", &D::free_play_stiffness_n_m_per_rad, "N m/rad",
       at_least(0), false, "a spring acting within the free play (an idle stage; 0: none)"},
      {"stage2_deg", &D::stage2_deg, "deg", open(0, 180), false,
       "the twist either way at which stage 2 engages; absent: no stage 2"},
      {"stage2_stiffness_n_m_per_rad", &D::stage2_stiffness_n_m_per_rad, "N m/rad", above(0), false,
       "stage 2's stiffness (with stage2_deg)"},
      {"stop_deg", &D::stop_deg, "deg", open(0, 180), false,
       "the twist either way at which the stop closes; absent: no stop"},
      {"stop_stiffness_n_m_per_rad", &D::stop_stiffness_n_m_per_rad, "N m/rad", above(0), false,
       "the stop's stiffness (with stop_deg)"},
      {"damping_n_m_s_per_rad", &D::damping_n_m_s_per_rad, "N m s/rad", at_least(0), false,
       "viscous damping on the twist's rate, in every stage but a free play without an idle "
       "spring"},
  };
  return keys;
}

}  // namespace geardyn
