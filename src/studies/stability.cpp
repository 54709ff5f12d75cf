#include "geardyn/stability.hpp"

#include <fmt/format.h>

#include <Eigen/Eigenvalues>
#include <Eigen/LU>
#include <Eigen/QR>
#include <algorithm>
#include <boost/math/tools/toms748_solve.hpp>
#include <cmath>
#include <map>
#include <nlohmann/json.hpp>
#include <utility>

#include "geardyn/case_keys.hpp"
#include "geardyn/engine.hpp"
#include "geardyn/orbit.hpp"
#include "geardyn/run.hpp"
#include "geardyn/train.hpp"
#include "geardyn/train_case.hpp"
#include "geardyn/train_presets.hpp"

namespace geardyn {
namespace {

// TOMS 748 iterations at most when locating a boundary.
constexpr std::uintmax_t kMaxBoundaryIterations = 200;
// Multipliers within this of the unit circle are neutral (the undamped system's stable
// multipliers lie on it, to rounding: about 1e-15 on the balanced monodromy): counted stable.
// A complex pair's boundary is where its modulus crosses 1 + kNeutralMargin, so that an
// undamped system's pair, which leaves the circle without crossing it, is located too.
constexpr double kNeutralMargin = 1e-9;
// A rigid motion's rate counts as kept by the flow (multiplier exactly 1) when M v - v is
// within this of M's size: rounding leaves some 1e-12 there, a drag of a millionth of the
// mesh damping some 1e-6.
constexpr double kNeutralRate = 1e-9;
// A freely turning train's contact flow is read on the complement of its rigid motions
// (elastic_quotient) where A T = T A_e holds to this fraction of A's largest entry: rounding
// leaves some 1e-16 there, a drag that grounds the rotation far more.
constexpr double kQuotientTolerance = 1e-12;

Case case_at(const Case& base, const SweepAxis& axis, double value) {
  Case c = base;
  set_case_value(c, {axis.key, fmt::format("{:.17g}", value),
                     fmt::format("--param {} at {}", axis.key, value)});
  return c;
}

double shifted_determinant(const ode::Matrix& m, double sign) {
  return (m - sign * ode::Matrix::Identity(m.rows(), m.cols())).determinant();
}

// |mu|^2 - (1 + kNeutralMargin)^2 of the largest complex pair; nullopt without one.
std::optional<double> complex_pair_test(const std::vector<std::complex<double>>& mu) {
  for (const auto& m : mu)
    if (std::abs(m.imag()) > 1e-12 * std::max(1.0, std::abs(m)))
      return std::norm(m) - (1 + kNeutralMargin) * (1 + kNeutralMargin);
  return std::nullopt;
}

}  // namespace

namespace {

// The homogeneous flow of region `contact` on the complement of a freely turning train's rigid
// motions U (n x k, the coordinates' part): with Z spanning {x : U^T M x = 0}, which M^-1 K(t)
// and M^-1 C(t) map into themselves when K U = C U = 0 (nothing grounds the motions), A(t) T =
// T A_e(t) for T = diag(Z, Z) and A_e = L A T, L = diag(Zp, Zp), Zp = (Z^T M Z)^-1 Z^T M. Its
// monodromy holds the elastic multipliers alone: the rigid ones (1 and its Jordan partner) are
// dropped exactly, and the flow has 2 k states fewer (the pair's train: the one-degree model's
// two). nullopt where A T = T A_e does not hold to kQuotientTolerance (a drag grounds them).
std::optional<ode::LinearSwitchedSystem> elastic_quotient(const ode::LinearSwitchedSystem& sys,
                                                          int contact, const ode::Matrix& mass,
                                                          const ode::Matrix& rigid) {
  const Eigen::Index n = mass.rows(), e = n - rigid.cols();
  const Eigen::HouseholderQR<ode::Matrix> qr(mass * rigid);
  const ode::Matrix z = (qr.householderQ() * ode::Matrix::Identity(n, n)).rightCols(e);
  const ode::Matrix zp = (z.transpose() * mass * z).ldlt().solve(z.transpose() * mass);
  ode::Matrix t = ode::Matrix::Zero(2 * n, 2 * e), l = ode::Matrix::Zero(2 * e, 2 * n);
  t.topLeftCorner(n, e) = z;
  t.bottomRightCorner(n, e) = z;
  l.topLeftCorner(e, n) = zp;
  l.bottomRightCorner(e, n) = zp;
  const ode::LinearRegion& r = sys.region(contact);
  double miss = 0, size = 0;
  const auto restrict = [&](const ode::Matrix& a) {
    ode::Matrix ae = l * a * t;
    miss = std::max(miss, (a * t - t * ae).cwiseAbs().maxCoeff());
    size = std::max(size, a.cwiseAbs().maxCoeff());
    return ae;
  };
  ode::LinearRegion q;
  q.a.constant = restrict(r.a.constant);
  for (const ode::Matrix& a : r.a.cos) q.a.cos.push_back(restrict(a));
  for (const ode::Matrix& a : r.a.sin) q.a.sin.push_back(restrict(a));
  if (!(miss <= kQuotientTolerance * size)) return std::nullopt;
  q.u.constant = ode::Vector::Zero(2 * e);  // the forcing does not enter the monodromy
  ode::LinearSwitchedSystem out;
  out.dimension = static_cast<int>(2 * e);
  out.frequencies_rad_s = sys.frequencies_rad_s;
  out.coefficient_period_s = sys.coefficient_period_s;
  out.regions = {std::move(q)};
  return out;
}

// The monodromy as contact_monodromy gives it, or with `elastic` without the rigid motions'
// multipliers of 1: a freely turning train's flow read on their complement (elastic_quotient),
// or its rigid rates' multipliers deflated (train.hpp, reduced_basis: a rate no drag damps maps
// to itself).
ode::Matrix monodromy_in_contact(const Case& c, double tolerance, double period_s,
                                 const MeshStiffness* stiffness, bool elastic) {
  ode::LinearSwitchedSystem sys;
  int contact = 0;
  double system_period = 0;
  std::optional<ode::Matrix> reduce;  // Q of the coordinates read (train::Assembled)
  ode::Matrix rates;                  // each rigid motion's rate (0, r), in the full state
  if (elastic || c.model.form == ModelForm::kTrain || c.model.form == ModelForm::kCoupled) {
    // Every mesh in drive contact, read in the train's own coordinates (reduced_basis); every
    // other form as its train (train_form_of) for the study (elastic), the one-degree model's
    // own flow below only for contact_monodromy (the checks' independent reference).
    const train::Assembled a = assembled_train(c, stiffness);
    if (elastic && a.train().speeds.empty()) {
      const Eigen::MatrixXd rigid = a.rigid_motions();
      rates = ode::Matrix::Zero(2 * static_cast<Eigen::Index>(a.size()), rigid.cols());
      rates.bottomRows(a.size()) = rigid;
    }
    sys = a.linear_system();
    // (A bearing with a clearance engaged, as the modes read it: its stiffness is the same on
    // either side, and the Floquet multipliers read only the homogeneous flow; every other
    // joint at its operating stage.)
    std::vector<int> joint_states;
    for (std::size_t j = 0; j < a.joints().size(); ++j)
      joint_states.push_back(
          a.operating_stages()[j] < 0 ? 1 : a.operating_stages()[j] - a.joints()[j].rest);
    contact = a.region(std::vector<int>(a.train().meshes.size(), 1), joint_states);
    // The system period is needed only where the meshes' stiffness is constant: the forcing
    // (torques, transmission errors) does not enter the monodromy.
    std::string why;
    const std::optional<double> period = a.system_period_s(&why);
    if (!(sys.coefficient_period_s > 0) && !(period_s > 0)) {
      if (!period) throw InputError(with_origins(c, "the train has no period: " + why));
      if (!(*period > 0))
        throw InputError(with_origins(
            c,
            "nothing in the train varies in time: in permanent contact it is a constant "
            "linear system, whose stability its modes' damping gives (geardyn modes)"));
    }
    system_period = period.value_or(0.0);
    reduce = a.reduced_basis();
    if (rates.cols() > 0)
      if (std::optional<ode::LinearSwitchedSystem> q =
              elastic_quotient(sys, contact, a.mass(), a.rigid_motions())) {
        sys = std::move(*q);
        contact = 0;
        reduce.reset();
        rates.resize(0, 0);
      }
  } else {
    const GearPairModel model = build_model(c, nullptr, stiffness);
    sys = model.linear_system();
    contact = kDriveContact - GearPairModel::kFirstRegion;
    system_period = system_period_s(model.parameters());
  }
  if (sys.lazy()) {
    // The one region read, held on its own (a lazy system builds its regions on demand).
    ode::LinearSwitchedSystem one;
    one.dimension = sys.dimension;
    one.frequencies_rad_s = sys.frequencies_rad_s;
    one.coefficient_period_s = sys.coefficient_period_s;
    one.regions = {sys.region(contact)};
    sys = std::move(one);
    contact = 0;
  }
  sys.regions[contact].guards.clear();  // permanent contact
  const double T = period_s > 0                   ? period_s
                   : sys.coefficient_period_s > 0 ? sys.coefficient_period_s
                                                  : system_period;
  ode::EngineOptions eo;
  eo.tolerance = std::max(ode::kRoundingLimit, tolerance);
  const ode::ExactEngine engine(sys, eo);
  ode::FlowObserver nothing;
  const ode::FlowResult r = engine.flow(0.0, ode::Vector::Zero(sys.dimension), contact, T,
                                        ode::OutputGrid{}, nothing, true);
  if (!r.ok() || !r.jacobian)
    throw std::runtime_error(fmt::format("the contact monodromy's flow failed ({}): {}",
                                         ode::to_string(r.termination), r.message));
  if (!reduce) return *r.jacobian;
  ode::Matrix m = reduce->transpose() * *r.jacobian * *reduce;
  if (rates.cols() == 0) return m;
  // A rate v the flow keeps (M v = v: nothing damps it) is a right eigenvector of 1; in an
  // orthonormal basis (V, W) M is block triangular, and W^T M W holds the other multipliers.
  // On the balanced M (balance, orbit.hpp: an exact similarity D^-1 M D, v to D^-1 v): what the
  // rounding of M v = v leaves in the dropped block W^T M V moves the others by its size times
  // that of V^T M W, which unbalanced (rates against angles and metres) reached 1e-9 of the
  // unit circle (the coupled pair's train, undamped).
  const ode::Vector d = balance(m);
  const ode::Matrix v = d.cwiseInverse().asDiagonal() * (reduce->transpose() * rates);
  const Eigen::HouseholderQR<ode::Matrix> qr(v);
  const ode::Matrix basis = qr.householderQ() * ode::Matrix::Identity(m.rows(), m.rows());
  const ode::Matrix kept = basis.leftCols(v.cols());
  if ((m * kept - kept).norm() > kNeutralRate * std::max(1.0, m.norm())) return m;
  const ode::Matrix w = basis.rightCols(m.rows() - v.cols());
  return w.transpose() * m * w;
}

}  // namespace

ode::Matrix contact_monodromy(const Case& c, double tolerance, double period_s,
                              const MeshStiffness* stiffness) {
  return monodromy_in_contact(c, tolerance, period_s, stiffness, false);
}

ode::Matrix elastic_contact_monodromy(const Case& c, double tolerance, double period_s,
                                      const MeshStiffness* stiffness) {
  return monodromy_in_contact(c, tolerance, period_s, stiffness, true);
}

std::string StabilityOptions::validate() const {
  auto check = [](const SweepAxis& a, const char* suffix) -> std::string {
    if (a.key.empty()) return fmt::format("--param{}: a numeric case key is required", suffix);
    if (std::string why = check_sweepable(a.key); !why.empty())
      return fmt::format("--param{} {}", suffix, why);
    if (!std::isfinite(a.from) || !std::isfinite(a.to) || a.from == a.to)
      return fmt::format("--from{0} = {1}, --to{0} = {2}: must be finite and differ", suffix,
                         a.from, a.to);
    if (a.points < 2 || a.points > 100000)
      return fmt::format("--points{} = {}: must be an integer in [2, 100000]", suffix, a.points);
    if (a.log && !(a.from > 0 && a.to > 0))
      return fmt::format("--log{0}: needs --from{0} and --to{0} > 0", suffix);
    return {};
  };
  if (std::string e = check(axis, ""); !e.empty()) return e;
  if (axis2) {
    if (std::string e = check(*axis2, "2"); !e.empty()) return e;
    if (static_cast<long long>(axis.points) * axis2->points > 1000000)
      return fmt::format("--points x --points2 = {} x {}: at most 1000000 samples", axis.points,
                         axis2->points);
  }
  if (!(tolerance >= ode::kRoundingLimit && tolerance <= 1e-3))
    return fmt::format("tolerance = {}: must be in [1e-16, 1e-3]", tolerance);
  return {};
}

StabilityResult stability(const Case& c, const StabilityOptions& o) {
  if (const std::string e = o.validate(); !e.empty()) throw InputError(e);
  StabilityResult res;
  const std::vector<double> rows = o.axis2 ? o.axis2->values() : std::vector<double>{0.0};
  const std::vector<double> values = o.axis.values();
  const double width = kBoundaryWidth * std::abs(o.axis.to - o.axis.from);
  const std::size_t total = rows.size() * values.size();
  std::vector<std::string> keys{o.axis.key};
  if (o.axis2) keys.push_back(o.axis2->key);
  // Every value the chart sets, against its key's bounds, before any work: the ends of each
  // range (its values lie between them), the least and largest given value.
  for (const auto& [axis, suffix] :
       {std::pair{&o.axis, ""}, std::pair{o.axis2 ? &*o.axis2 : nullptr, "2"}})
    if (axis)
      for (const AxisValue& end : axis_ends(*axis, suffix)) {
        Case at = c;
        set_case_value(at, {axis->key, fmt::format("{:.17g}", end.value), end.origin});
      }
  check_axes_read(c, o.axis, o.axis2 ? &*o.axis2 : nullptr);
  const std::optional<MeshStiffness> shared = shared_stiffness(c, keys);
  // A key the contact flow does not depend on (a backlash, a torque, a transmission error: they
  // force the motion, not its linearised flow) would chart the same multipliers everywhere:
  // refused when the monodromy is the same, bit for bit, at both ends of its axis (at every
  // end of the other axis of a map). A key that enters the flow changes it at its ends. The
  // monodromies found here are the chart's at those values: kept by (row, value), the row
  // being the value of --param2 (0 without one).
  std::map<std::pair<double, double>, ode::Matrix> found;
  for (const auto& [varied, suffix, held] :
       {std::tuple{&o.axis, "", o.axis2 ? &*o.axis2 : nullptr},
        std::tuple{o.axis2 ? &*o.axis2 : nullptr, "2", &o.axis}}) {
    const SweepAxis* axis = varied;  // plain pointers: a lambda below captures them
    const SweepAxis* other = held;
    if (!axis) continue;
    const std::vector<AxisValue> ends = axis_ends(*axis, suffix);
    const std::vector<AxisValue> others =
        other ? axis_ends(*other, suffix[0] ? "" : "2") : std::vector<AxisValue>{{0.0, ""}};
    bool enters = false;
    for (const AxisValue& at : others) {
      const Case row = other ? case_at(c, *other, at.value) : c;
      const auto flow = [&](double v) {
        const std::pair<double, double> at_key =
            axis == &o.axis ? std::pair{at.value, v} : std::pair{v, at.value};
        auto [it, fresh] = found.try_emplace(at_key);
        if (fresh)
          it->second = elastic_contact_monodromy(case_at(row, *axis, v), o.tolerance, 0,
                                                 shared ? &*shared : nullptr);
        return it->second;
      };
      enters = enters || flow(ends.front().value) != flow(ends.back().value);
    }
    if (!enters)
      throw InputError(fmt::format(
          "--param{} {}: the stability in permanent contact does not depend on it: the contact "
          "flow's monodromy is the same at {} and at {} (a backlash, a torque or a transmission "
          "error forces the motion without entering its linearised flow; `geardyn sweep` and "
          "`geardyn continue` read it)",
          suffix, axis->key, ends.front().origin, ends.back().origin));
  }
  for (const double row : rows) {
    const Case base = o.axis2 ? case_at(c, *o.axis2, row) : c;
    auto monodromy = [&](double p) {
      if (const auto it = found.find({o.axis2 ? row : 0.0, p}); it != found.end())
        return it->second;
      return elastic_contact_monodromy(case_at(base, o.axis, p), o.tolerance, 0,
                                       shared ? &*shared : nullptr);
    };
    auto locate = [&](double a, double b, double fa, double fb, BifurcationType type,
                      const std::function<double(const ode::Matrix&)>& test) {
      std::uintmax_t iterations = kMaxBoundaryIterations;
      const auto f = [&](double p) { return test(monodromy(p)); };
      const auto bracket = boost::math::tools::toms748_solve(
          f, a, b, fa, fb, [width](double x, double y) { return std::abs(y - x) <= width; },
          iterations);
      res.boundaries.push_back({0.5 * (bracket.first + bracket.second), row, type});
    };
    ode::Matrix prev;
    double prev_p = 0;
    for (std::size_t i = 0; i < values.size(); ++i) {
      const double p = values[i];
      const ode::Matrix m = monodromy(p);
      StabilitySample s;
      s.param = p;
      s.param2 = row;
      s.multipliers = floquet_multipliers(m);
      s.max_multiplier = s.multipliers.empty() ? 0.0 : std::abs(s.multipliers.front());
      s.stable = s.max_multiplier < 1.0 + kNeutralMargin;
      if (i > 0) {
        for (const double sign : {1.0, -1.0}) {
          const auto test = [sign](const ode::Matrix& x) { return shifted_determinant(x, sign); };
          const double fa = test(prev), fb = test(m);
          if (fa * fb < 0)
            locate(prev_p, p, fa, fb,
                   sign > 0 ? BifurcationType::kFold : BifurcationType::kPeriodDoubling, test);
        }
        const auto na = complex_pair_test(floquet_multipliers(prev));
        const auto nb = complex_pair_test(s.multipliers);
        if (na && nb && *na * *nb < 0)
          locate(prev_p, p, *na, *nb, BifurcationType::kNeimarkSacker, [](const ode::Matrix& x) {
            return complex_pair_test(floquet_multipliers(x)).value_or(0.0);
          });
      }
      res.samples.push_back(std::move(s));
      prev = m;
      prev_p = p;
      if (o.progress && !o.progress(res.samples.size(), total)) {
        res.cancelled = true;
        return res;
      }
    }
  }
  std::sort(res.boundaries.begin(), res.boundaries.end(),
            [](const StabilityBoundary& a, const StabilityBoundary& b) {
              return a.param2 != b.param2 ? a.param2 < b.param2 : a.param < b.param;
            });
  return res;
}

}  // namespace geardyn
