#include "geardyn/analysis.hpp"

#include <algorithm>
#include <array>
#include <cmath>
#include <limits>

namespace geardyn {

const char* to_string(Regime r) {
  switch (r) {
    case Regime::kNone:
      return "none";
    case Regime::kTransient:
      return "transient";
    case Regime::kSustained:
      return "sustained";
  }
  return "?";
}

const char* to_string(EventKind k) {
  switch (k) {
    case EventKind::kImpact:
      return "impact";
    case EventKind::kBacksideImpact:
      return "backside_impact";
    case EventKind::kSeparation:
      return "separation";
  }
  return "?";
}

Regime regime_of(bool separated_in_final, double separated_time_s) {
  if (separated_in_final) return Regime::kSustained;
  return separated_time_s > 0 ? Regime::kTransient : Regime::kNone;
}

}  // namespace geardyn
