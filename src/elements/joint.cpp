#include "geardyn/joint.hpp"

#include <algorithm>

namespace geardyn::train {

int Joint::stage_at(double x) const {
  return static_cast<int>(std::upper_bound(edges.begin(), edges.end(), x) - edges.begin());
}

double Joint::energy(double x) const {
  // The spring force of stage s integrated from a to b.
  const auto work = [&](int s, double a, double b) {
    const JointStage& g = stages[static_cast<std::size_t>(s)];
    return 0.5 * g.stiffness * (b * b - a * a) + g.force_at_zero * (b - a);
  };
  const int from = stage_at(0.0), to = stage_at(x);
  if (from == to) return work(to, 0.0, x);
  double e = 0, at = 0;
  if (to > from) {
    for (int s = from; s < to; ++s) {
      e += work(s, at, edges[static_cast<std::size_t>(s)]);
      at = edges[static_cast<std::size_t>(s)];
    }
  } else {
    for (int s = from; s > to; --s) {
      e += work(s, at, edges[static_cast<std::size_t>(s - 1)]);
      at = edges[static_cast<std::size_t>(s - 1)];
    }
  }
  return e + work(to, at, x);
}

}  // namespace geardyn::train
