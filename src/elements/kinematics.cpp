#include "geardyn/kinematics.hpp"

#include <fmt/format.h>
#include <fmt/ranges.h>

#include <cstdlib>
#include <limits>
#include <numeric>
#include <optional>
#include <queue>

#include "geardyn/input_error.hpp"

namespace geardyn::train {
namespace {

// 128-bit products of 64-bit ratios, narrowed back after reduction (a GNU extension).
__extension__ using Wide = __int128;

[[noreturn]] void bad(const std::string& element, const std::string& what) {
  throw InputError(fmt::format("{}: {}", element, what));
}

Wide gcd_wide(Wide a, Wide b) {
  if (a < 0) a = -a;
  if (b < 0) b = -b;
  while (b != 0) {
    const Wide r = a % b;
    a = b;
    b = r;
  }
  return a;
}

// num / den reduced, den > 0, both within 64 bits.
Ratio narrow(Wide num, Wide den) {
  if (den < 0) {
    num = -num;
    den = -den;
  }
  const Wide g = gcd_wide(num, den);
  if (g > 1) {
    num /= g;
    den /= g;
  }
  constexpr Wide kMax = std::numeric_limits<std::int64_t>::max();
  if (num > kMax || -num > kMax || den > kMax)
    bad("the train",
        "its speed ratios need more than 18 digits (teeth counts whose products "
        "no 64-bit ratio holds): check the teeth counts");
  return {static_cast<std::int64_t>(num), static_cast<std::int64_t>(den)};
}

Ratio product(Ratio a, Ratio b) {
  return narrow(static_cast<Wide>(a.num) * b.num, static_cast<Wide>(a.den) * b.den);
}

Ratio quotient(Ratio a, Ratio b) {
  return narrow(static_cast<Wide>(a.num) * b.den, static_cast<Wide>(a.den) * b.num);
}

bool zero(Ratio a) { return a.num == 0; }

// An exact reduced row echelon form, grown one constraint at a time: rows hold the unknowns'
// coefficients and, last, the right-hand side.
class Elimination {
 public:
  explicit Elimination(int unknowns) : n_(unknowns) {}

  // Adds a row; false when it contradicts those before it (0 = non-zero).
  bool add(std::vector<Ratio> row) {
    for (std::size_t k = 0; k < rows_.size(); ++k) {
      const Ratio f = row[static_cast<std::size_t>(pivot_[k])];
      if (zero(f)) continue;
      for (int j = 0; j <= n_; ++j)
        row[j] = minus(row[j], product(f, rows_[k][static_cast<std::size_t>(j)]));
    }
    int p = 0;
    while (p < n_ && zero(row[static_cast<std::size_t>(p)])) ++p;
    if (p == n_) return zero(row[static_cast<std::size_t>(n_)]);
    const Ratio f = row[static_cast<std::size_t>(p)];
    for (Ratio& x : row) x = quotient(x, f);
    for (auto& r : rows_) {
      const Ratio g = r[static_cast<std::size_t>(p)];
      if (zero(g)) continue;
      for (int j = 0; j <= n_; ++j)
        r[j] = minus(r[j], product(g, row[static_cast<std::size_t>(j)]));
    }
    rows_.push_back(std::move(row));
    pivot_.push_back(p);
    return true;
  }

  // Unknown j's value when the rows fix it alone.
  std::optional<Ratio> value_of(int j) const {
    for (std::size_t k = 0; k < rows_.size(); ++k) {
      if (pivot_[k] != j) continue;
      for (int i = 0; i < n_; ++i)
        if (i != j && !zero(rows_[k][static_cast<std::size_t>(i)])) return std::nullopt;
      return rows_[k][static_cast<std::size_t>(n_)];
    }
    return std::nullopt;
  }

 private:
  int n_;
  std::vector<std::vector<Ratio>> rows_;
  std::vector<int> pivot_;
};

}  // namespace

Ratio reduced(std::int64_t num, std::int64_t den) { return narrow(num, den); }

Ratio times(Ratio a, std::int64_t num, std::int64_t den) { return product(a, narrow(num, den)); }

Ratio plus(Ratio a, Ratio b) {
  return narrow(static_cast<Wide>(a.num) * b.den + static_cast<Wide>(b.num) * a.den,
                static_cast<Wide>(a.den) * b.den);
}

Ratio minus(Ratio a, Ratio b) { return plus(a, Ratio{-b.num, b.den}); }

Ratio absolute(Ratio a) { return {std::abs(a.num), a.den}; }

bool same(Ratio a, Ratio b) { return a.num == b.num && a.den == b.den; }

double value(Ratio r) { return static_cast<double>(r.num) / static_cast<double>(r.den); }

Ratio NominalMotion::relative(int body, int f) const {
  const auto i = static_cast<std::size_t>(body);
  if (f < 0) return speed[i];
  const auto c = static_cast<std::size_t>(f);
  // s_i (w_i - w_c) = speed_i - s_i s_c speed_c.
  return minus(speed[i], times(speed[c], static_cast<std::int64_t>(sense[i]) * sense[c], 1));
}

Ratio NominalMotion::mesh_frequency(int mesh, const KinematicGraph& g) const {
  const KinematicGraph::Mesh& m = g.meshes[static_cast<std::size_t>(mesh)];
  return absolute(times(relative(m.a, mesh_frame[static_cast<std::size_t>(mesh)]), m.teeth_a, 1));
}

NominalMotion solve_nominal_motion(const KinematicGraph& g) {
  const int n = static_cast<int>(g.bodies.size());
  const auto name = [&](int i) { return g.bodies[static_cast<std::size_t>(i)]; };
  NominalMotion out;
  out.is_carrier.assign(static_cast<std::size_t>(n), false);

  // Each body's carrier, from the pins.
  std::vector<int> carrier_of(static_cast<std::size_t>(n), kGroundFrame);
  for (const KinematicGraph::Pin& p : g.pins) {
    int& c = carrier_of[static_cast<std::size_t>(p.body)];
    if (c != kGroundFrame && c != p.carrier)
      bad(p.element, fmt::format("body '{}' rides on pins of '{}' and '{}': a body has one "
                                 "carrier",
                                 name(p.body), name(c), name(p.carrier)));
    c = p.carrier;
    out.is_carrier[static_cast<std::size_t>(p.carrier)] = true;
    for (const KinematicGraph::Mesh& m : g.meshes)
      if ((m.a == p.body && m.b == p.carrier) || (m.b == p.body && m.a == p.carrier))
        bad(p.element,
            fmt::format("body '{}' carries bodies on pins and meshes with one of them ('{}', "
                        "in {}): a carrier holds its planets' axes, the planets mesh with the "
                        "sun and the ring",
                        name(p.carrier), name(p.body), m.element));
  }
  // Each mesh's frame: the carrier of the gear on a pin.
  for (const KinematicGraph::Mesh& m : g.meshes) {
    const int ca = carrier_of[static_cast<std::size_t>(m.a)],
              cb = carrier_of[static_cast<std::size_t>(m.b)];
    if (ca != kGroundFrame && cb != kGroundFrame && ca != cb)
      bad(m.element, fmt::format("its gears ride on pins of two carriers ('{}' and '{}'): a mesh "
                                 "turns in one carrier's frame",
                                 name(ca), name(cb)));
    const int f = ca != kGroundFrame ? ca : cb;
    if (f == m.a || f == m.b)
      bad(m.element,
          fmt::format("body '{}' carries bodies on pins and meshes with one of them: a carrier "
                      "holds its planets' axes, the planets mesh with the sun and the ring",
                      name(f)));
    out.mesh_frame.push_back(f);
  }

  // Joined to the reference at all: through meshes, shafts and pins.
  {
    std::vector<bool> seen(static_cast<std::size_t>(n), false);
    std::queue<int> open;
    seen[static_cast<std::size_t>(g.reference)] = true;
    open.push(g.reference);
    const auto reach = [&](int j) {
      if (!seen[static_cast<std::size_t>(j)]) {
        seen[static_cast<std::size_t>(j)] = true;
        open.push(j);
      }
    };
    while (!open.empty()) {
      const int i = open.front();
      open.pop();
      for (const auto& m : g.meshes) {
        if (m.a == i) reach(m.b);
        if (m.b == i) reach(m.a);
      }
      for (const auto& s : g.shafts) {
        if (s.b == KinematicGraph::kToGround) continue;
        if (s.a == i) reach(s.b);
        if (s.b == i) reach(s.a);
      }
      for (const auto& p : g.pins) {
        if (p.body == i) reach(p.carrier);
        if (p.carrier == i) reach(p.body);
      }
    }
    for (int i = 0; i < n; ++i)
      if (!seen[static_cast<std::size_t>(i)])
        bad(fmt::format("body '{}'", name(i)),
            fmt::format("is joined to the reference '{}' by no mesh, shaft or pin",
                        name(g.reference)));
  }

  // The senses, part by part: an external mesh reverses, an internal mesh and a shaft keep.
  out.sense.assign(static_cast<std::size_t>(n), 0);
  std::vector<int> part(static_cast<std::size_t>(n), -1);
  std::vector<int> roots;
  for (int root : [&] {
         std::vector<int> order{g.reference};
         for (int i = 0; i < n; ++i)
           if (i != g.reference) order.push_back(i);
         return order;
       }()) {
    if (part[static_cast<std::size_t>(root)] >= 0) continue;
    const int id = static_cast<int>(roots.size());
    roots.push_back(root);
    part[static_cast<std::size_t>(root)] = id;
    out.sense[static_cast<std::size_t>(root)] = 1;
    std::queue<int> open;
    open.push(root);
    while (!open.empty()) {
      const int i = open.front();
      open.pop();
      const int si = out.sense[static_cast<std::size_t>(i)];
      const auto visit = [&](int j, int s, const std::string& element) {
        int& sj = out.sense[static_cast<std::size_t>(j)];
        if (sj == 0) {
          sj = s;
          part[static_cast<std::size_t>(j)] = id;
          open.push(j);
        } else if (sj != s) {
          bad(element, fmt::format("closes a loop whose senses of rotation disagree (body '{}' "
                                   "would turn both ways; an odd loop of external meshes): the "
                                   "train is locked and cannot turn",
                                   name(j)));
        }
      };
      for (const auto& m : g.meshes) {
        const int next = (m.internal ? 1 : -1) * si;
        if (m.a == i) visit(m.b, next, m.element);
        if (m.b == i) visit(m.a, next, m.element);
      }
      for (const auto& s : g.shafts) {
        if (s.b == KinematicGraph::kToGround) continue;
        if (s.a == i) visit(s.b, si, s.element);
        if (s.b == i) visit(s.a, si, s.element);
      }
    }
  }

  // The absolute speeds w (counterclockwise, over w_ref): the reference, then every mesh and
  // shaft, then the supports, so that a support holding a turning body is the one named.
  Elimination e(n);
  const auto row = [&] { return std::vector<Ratio>(static_cast<std::size_t>(n) + 1, Ratio{0, 1}); };
  {
    std::vector<Ratio> r = row();
    r[static_cast<std::size_t>(g.reference)] = {1, 1};
    r[static_cast<std::size_t>(n)] = {1, 1};
    e.add(std::move(r));
  }
  // "({} against {} for body '{}')" when the others of a contradicting row are known.
  const auto disagreement = [&](const std::vector<Ratio>& r) -> std::string {
    for (int j = n - 1; j >= 0; --j) {
      if (zero(r[static_cast<std::size_t>(j)])) continue;
      const std::optional<Ratio> known = e.value_of(j);
      if (!known) continue;
      Ratio rest = r[static_cast<std::size_t>(n)];
      bool all = true;
      for (int i = 0; i < n && all; ++i) {
        if (i == j || zero(r[static_cast<std::size_t>(i)])) continue;
        const std::optional<Ratio> v = e.value_of(i);
        if (!v)
          all = false;
        else
          rest = minus(rest, product(r[static_cast<std::size_t>(i)], *v));
      }
      if (!all) continue;
      const Ratio implied = quotient(rest, r[static_cast<std::size_t>(j)]);
      const int s = out.sense[static_cast<std::size_t>(j)];
      return fmt::format(" ({:.6g} against {:.6g} for body '{}')", s * value(implied),
                         s * value(*known), name(j));
    }
    return "";
  };
  // A mesh's or a shaft's row, refused naming it where it contradicts the rows before it.
  const auto close_loop = [&](const std::vector<Ratio>& r, const std::string& element) {
    const std::string why = disagreement(r);
    if (!e.add(r))
      bad(element, fmt::format("closes a loop whose speed ratios disagree{}: the train is "
                               "locked and cannot turn",
                               why));
  };
  for (std::size_t k = 0; k < g.meshes.size(); ++k) {
    const KinematicGraph::Mesh& m = g.meshes[k];
    // z_a (w_a - w_c) + sigma z_b (w_b - w_c) = 0, sigma = 1 external, -1 internal.
    const std::int64_t sigma = m.internal ? -1 : 1;
    std::vector<Ratio> r = row();
    r[static_cast<std::size_t>(m.a)] = {m.teeth_a, 1};
    r[static_cast<std::size_t>(m.b)] = {sigma * m.teeth_b, 1};
    if (const int c = out.mesh_frame[k]; c != kGroundFrame)
      r[static_cast<std::size_t>(c)] = {-(m.teeth_a + sigma * m.teeth_b), 1};
    close_loop(r, m.element);
  }
  for (const auto& s : g.shafts) {
    if (s.b == KinematicGraph::kToGround) continue;
    std::vector<Ratio> r = row();
    r[static_cast<std::size_t>(s.a)] = {1, 1};
    r[static_cast<std::size_t>(s.b)] = {-1, 1};
    close_loop(r, s.element);
  }
  for (const auto& s : g.shafts) {
    if (s.b != KinematicGraph::kToGround) continue;
    std::vector<Ratio> r = row();
    r[static_cast<std::size_t>(s.a)] = {1, 1};
    const std::optional<Ratio> turning = e.value_of(s.a);
    if (!e.add(r))
      bad(s.element,
          fmt::format("holds body '{}' to the ground (a support: it cannot turn), but the train "
                      "turns it{}: the train is locked. A support holds a planetary set's ring, "
                      "sun or carrier in its housing; two turning bodies are joined by a shaft",
                      name(s.a),
                      turning
                          ? fmt::format(" at {:.6g} times the reference's speed",
                                        out.sense[static_cast<std::size_t>(s.a)] * value(*turning))
                          : std::string()));
  }
  std::vector<std::string> free;
  out.speed.resize(static_cast<std::size_t>(n));
  for (int i = 0; i < n; ++i) {
    const std::optional<Ratio> w = e.value_of(i);
    if (!w) {
      free.push_back(fmt::format("'{}'", name(i)));
      continue;
    }
    out.speed[static_cast<std::size_t>(i)] = times(*w, out.sense[static_cast<std::size_t>(i)], 1);
  }
  if (!free.empty())
    bad("the train",
        fmt::format("the reference's speed leaves the speeds of {} free: a planetary set with no "
                    "member held turns in two ways at once (a differential). Hold one member "
                    "(its ring, sun or carrier) with a [[train.shaft]] to \"ground\", or join it "
                    "by a shaft to a body whose speed is known",
                    fmt::join(free, ", ")));

  // Each part the reference's does not hold turns forward relative to its first mesh's frame.
  for (std::size_t p = 1; p < roots.size(); ++p) {
    int flip = 0;
    for (std::size_t k = 0; k < g.meshes.size() && flip == 0; ++k) {
      const int a = g.meshes[k].a;
      if (part[static_cast<std::size_t>(a)] != static_cast<int>(p)) continue;
      const Ratio r = out.relative(a, out.mesh_frame[k]);
      if (r.num != 0) flip = r.num < 0 ? -1 : 1;
    }
    if (flip >= 0) continue;
    for (int i = 0; i < n; ++i)
      if (part[static_cast<std::size_t>(i)] == static_cast<int>(p)) {
        out.sense[static_cast<std::size_t>(i)] *= -1;
        out.speed[static_cast<std::size_t>(i)] =
            times(out.speed[static_cast<std::size_t>(i)], -1, 1);
      }
  }

  // Each body's frame for its translations.
  out.frame.assign(static_cast<std::size_t>(n), kGroundFrame);
  for (int i = 0; i < n; ++i) {
    if (out.is_carrier[static_cast<std::size_t>(i)]) {
      out.frame[static_cast<std::size_t>(i)] = i;
      continue;
    }
    if (carrier_of[static_cast<std::size_t>(i)] != kGroundFrame) {
      out.frame[static_cast<std::size_t>(i)] = carrier_of[static_cast<std::size_t>(i)];
      continue;
    }
    std::optional<int> f;
    for (std::size_t k = 0; k < g.meshes.size(); ++k) {
      if (g.meshes[k].a != i && g.meshes[k].b != i) continue;
      if (f && *f != out.mesh_frame[k]) {
        f = kMixedFrame;
        break;
      }
      f = out.mesh_frame[k];
    }
    out.frame[static_cast<std::size_t>(i)] = f.value_or(kGroundFrame);
  }
  return out;
}

}  // namespace geardyn::train
