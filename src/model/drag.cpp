#include "geardyn/drag.hpp"

#include <fmt/format.h>

#include <cstdint>
#include <utility>

#include "geardyn/input_error.hpp"
#include "geardyn/train.hpp"
#include "model/element_keys.hpp"

namespace geardyn {
namespace {

using namespace element_keys;

class Drag final : public train::Element {
 public:
  explicit Drag(TrainDragData d) : d_(std::move(d)) {}

  std::string label() const override { return fmt::format("drag '{}'", d_.name); }
  std::vector<std::array<std::string, 2>> bodies() const override { return {{"body", d_.body}}; }

  // One joint on x = theta of one stage: f = sign(w) T_c + c x' (the joint's force pushes x
  // back, so the torque on the body is -f).
  std::vector<train::Joint> joints(const train::Assembled& a) const override {
    const int body = a.index(d_.body);
    if (a.prescribed(body))
      throw InputError(fmt::format(
          "{}: body = \"{}\": its speed is prescribed, so no drag acts on it", label(), d_.body));
    const std::int64_t turning = a.speed_ratios()[static_cast<std::size_t>(body)].num;
    if (turning == 0 && d_.constant_nm != 0)
      throw InputError(fmt::format(
          "{}: body = \"{}\" is at rest: a constant drag has no rotation to oppose (give its "
          "viscous part only)",
          label(), d_.body));
    train::Joint j;
    j.name = d_.name;
    j.row = Eigen::RowVectorXd::Zero(a.size());
    j.row(body) = 1;
    j.stages = {{0.0, (turning < 0 ? -1.0 : 1.0) * d_.constant_nm, d_.viscous_n_m_s_per_rad}};
    return {j};
  }

 private:
  TrainDragData d_;
};

}  // namespace

std::shared_ptr<const train::Element> TrainDragData::element() const {
  return std::make_shared<Drag>(*this);
}

const std::vector<ElementKey<TrainDragData>>& drag_keys() {
  using D = TrainDragData;
  static const std::vector<ElementKey<D>> keys = {
      {"name", &D::name, "", {}, false, "the drag's name"},
      {"body", &D::body, "", {}, true, "the body it acts on"},
      {"constant_nm", &D::constant_nm, "N m", at_least(0), false,
       "constant drag torque against the rotation"},
      {"viscous_n_m_s_per_rad", &D::viscous_n_m_s_per_rad, "N m s/rad", at_least(0), false,
       "viscous drag on the body's speed fluctuation"},
  };
  return keys;
}

}  // namespace geardyn
