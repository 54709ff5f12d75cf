#include "geardyn/case.hpp"

#include <fmt/format.h>
#include <toml++/toml.h>

#include <algorithm>
#include <cmath>
#include <fstream>
#include <map>
#include <nlohmann/json.hpp>
#include <set>
#include <sstream>

#include "geardyn/harmonic_series.hpp"

namespace geardyn {
namespace {

// The smallest half backlash accepted, um.
constexpr double kMinBacklashUm = 1e-3;

// Where a node came from, for messages: "case.toml:12:5" or "--set mesh.backlash_um=-1".
std::string where(const toml::source_region& src, const std::string& fallback) {
  if (!src.path || src.path->empty()) return fallback;
  const std::string& path = *src.path;
  if (path.rfind("--set", 0) == 0) return path;
  if (src.begin.line == 0) return path;
  return fmt::format("{}:{}:{}", path, src.begin.line, src.begin.column);
}

std::string node_text(const toml::node& n) {
  std::ostringstream out;
  n.visit([&](auto&& v) {
    if constexpr (toml::is_string<decltype(v)>) {
      out << '"' << v.get() << '"';
    } else {
      out << v;
    }
  });
  std::string s = out.str();
  for (char& ch : s) {
    if (ch == '\n') ch = ' ';
  }
  return s;
}

std::string format_number(double x) { return fmt::format("{}", x); }

// A broken bound found in a decoded case: the dotted key (with [i] for array elements), the value
// as text, and what is allowed.
struct Violation {
  std::string key;
  std::string value;
  std::string allowed;
};

using MaybeViolation = std::optional<Violation>;

// The ranges of every value, written once; used for case files and for cases built in code.
// Conditions are written so that NaN fails them.
MaybeViolation check_ranges(const Case& c) {
  auto bad = [](std::string key, double v, std::string allowed) {
    return MaybeViolation(Violation{std::move(key), format_number(v), std::move(allowed)});
  };
  const ModelData& md = c.model;
  if (!(md.zeta >= 0 && md.zeta < 1))
    return bad("model.zeta", md.zeta, "a damping ratio in [0, 1)");
  if (!std::isfinite(md.force_mean))
    return bad("model.force_mean", md.force_mean, "a finite force");
  if (!(md.force_alternating >= 0 && std::isfinite(md.force_alternating)))
    return bad("model.force_alternating", md.force_alternating, "a finite amplitude >= 0");
  if (!(md.omega > 0 && std::isfinite(md.omega)))
    return bad("model.omega", md.omega, "a finite frequency ratio > 0");
  double kappa_sum = 0;
  for (std::size_t i = 0; i < md.stiffness_harmonics.size(); ++i) {
    if (!(md.stiffness_harmonics[i].ratio >= 0 && md.stiffness_harmonics[i].ratio < 1))
      return bad(fmt::format("model.stiffness_harmonics[{}][0]", i),
                 md.stiffness_harmonics[i].ratio, "a ratio in [0, 1)");
    kappa_sum += md.stiffness_harmonics[i].ratio;
  }
  if (!(kappa_sum < 1))
    return bad("model.stiffness_harmonics", kappa_sum, "ratios whose sum is < 1 (k stays > 0)");
  if (md.stiffness_harmonics.size() > static_cast<std::size_t>(HarmonicSeries::kMaxTerms))
    return bad("model.stiffness_harmonics", static_cast<double>(md.stiffness_harmonics.size()),
               fmt::format("at most {} harmonics", HarmonicSeries::kMaxTerms));

  const GearData& g = c.gear;
  if (!(g.normal_module_mm > 0 && g.normal_module_mm <= 100))
    return bad("gear.normal_module_mm", g.normal_module_mm, "a module in (0, 100] mm");
  if (!(g.normal_pressure_angle_deg > 0 && g.normal_pressure_angle_deg < 45))
    return bad("gear.normal_pressure_angle_deg", g.normal_pressure_angle_deg,
               "an angle in (0, 45) degrees");
  if (!(g.helix_angle_deg >= 0 && g.helix_angle_deg < 60))
    return bad("gear.helix_angle_deg", g.helix_angle_deg,
               "an angle in [0, 60) degrees (0 is a spur gear)");
  if (!(g.center_distance_mm > 0))
    return bad("gear.center_distance_mm", g.center_distance_mm, "a distance > 0 mm");
  for (int i = 0; i < 2; ++i) {
    if (!(g.teeth[i] >= 5 && g.teeth[i] <= 10000))
      return bad(fmt::format("gear.teeth[{}]", i), g.teeth[i],
                 "a whole number of teeth from 5 to 10000 (external gears)");
  }
  if (!(g.face_width_mm > 0)) return bad("gear.face_width_mm", g.face_width_mm, "a width > 0 mm");
  for (int i = 0; i < 2; ++i) {
    if (!(g.outside_diameter_mm[i] > 0))
      return bad(fmt::format("gear.outside_diameter_mm[{}]", i), g.outside_diameter_mm[i],
                 "a diameter > 0 mm");
    if (!(g.profile_shift[i] >= -1.5 && g.profile_shift[i] <= 1.5))
      return bad(fmt::format("gear.profile_shift[{}]", i), g.profile_shift[i],
                 "a profile shift coefficient in [-1.5, 1.5]");
    if (!(g.bore_diameter_mm[i] >= 0))
      return bad(fmt::format("gear.bore_diameter_mm[{}]", i), g.bore_diameter_mm[i],
                 "a diameter >= 0 mm (0 is a solid blank)");
    if (!(g.youngs_modulus_gpa[i] > 0 && g.youngs_modulus_gpa[i] < 2000))
      return bad(fmt::format("gear.youngs_modulus_gpa[{}]", i), g.youngs_modulus_gpa[i],
                 "a Young's modulus in (0, 2000) GPa");
    if (!(g.poisson_ratio[i] >= 0 && g.poisson_ratio[i] < 0.5))
      return bad(fmt::format("gear.poisson_ratio[{}]", i), g.poisson_ratio[i],
                 "a Poisson's ratio in [0, 0.5)");
    if (!(g.basic_rack_dedendum[i] >= 1.0 && g.basic_rack_dedendum[i] <= 1.6))
      return bad(fmt::format("gear.basic_rack_dedendum[{}]", i), g.basic_rack_dedendum[i],
                 "a basic rack dedendum h_fP/m_n in [1, 1.6] (ISO 53: 1.25 to 1.4)");
    if (!(g.rim_thickness_mm[i] >= 0))
      return bad(fmt::format("gear.rim_thickness_mm[{}]", i), g.rim_thickness_mm[i],
                 "a thickness >= 0 mm (0: solid blank)");
    if (!(g.web_thickness_mm[i] >= 0))
      return bad(fmt::format("gear.web_thickness_mm[{}]", i), g.web_thickness_mm[i],
                 "a thickness >= 0 mm (0: solid blank)");
    if (g.inertia_kg_m2 && !((*g.inertia_kg_m2)[i] > 0 && std::isfinite((*g.inertia_kg_m2)[i])))
      return bad(fmt::format("gear.inertia_kg_m2[{}]", i), (*g.inertia_kg_m2)[i],
                 "a finite moment of inertia > 0 kg m^2");
  }
  if (!(g.density_kg_m3 > 0 && std::isfinite(g.density_kg_m3)))
    return bad("gear.density_kg_m3", g.density_kg_m3, "a finite density > 0 kg/m^3");

  const MeshData& m = c.mesh;
  // Below a nanometre the backlash is no gear's, and its products underflow (a denormal b
  // makes the integrators' absolute tolerance tolerance x b zero).
  if (!(m.backlash_um >= kMinBacklashUm && std::isfinite(m.backlash_um)))
    return bad("mesh.backlash_um", m.backlash_um,
               "a finite half backlash b of at least 0.001 um (1 nm; the total normal backlash "
               "is 2b)");
  if (m.stiffness_source == StiffnessSource::kHarmonics) {
    if (!(m.mean_stiffness_n_per_m > 0 && std::isfinite(m.mean_stiffness_n_per_m)))
      return bad("mesh.mean_stiffness_n_per_m", m.mean_stiffness_n_per_m,
                 "a finite stiffness > 0 N/m with mesh.stiffness_source = \"harmonics\"");
  } else if (!(m.mean_stiffness_n_per_m >= 0 && std::isfinite(m.mean_stiffness_n_per_m))) {
    return bad("mesh.mean_stiffness_n_per_m", m.mean_stiffness_n_per_m,
               "a finite stiffness > 0 N/m to scale the computed curve to, or 0 to keep its mean");
  }
  if (!(m.harmonics_kept >= 0 && m.harmonics_kept <= HarmonicSeries::kMaxTerms))
    return bad("mesh.harmonics_kept", m.harmonics_kept,
               fmt::format("a whole number from 0 to {}", HarmonicSeries::kMaxTerms));
  if (!(m.stiffness_positions >= 16 && m.stiffness_positions <= 65536))
    return bad("mesh.stiffness_positions", m.stiffness_positions,
               "a whole number of mesh positions from 16 to 65536");
  if (m.harmonics_kept >= m.stiffness_positions / 2)
    return bad("mesh.harmonics_kept", m.harmonics_kept,
               "fewer than half of mesh.stiffness_positions");
  if (!(m.stiffness_slices >= 1 && m.stiffness_slices <= 4096))
    return bad("mesh.stiffness_slices", m.stiffness_slices,
               "a whole number of face-width slices from 1 to 4096");
  if (!(m.application_factor >= 1 && m.application_factor <= 5))
    return bad("mesh.application_factor", m.application_factor,
               "an application factor K_A in [1, 5]");
  if (m.stiffness_source != StiffnessSource::kHarmonics && !m.stiffness_harmonics.empty())
    return MaybeViolation(Violation{
        "mesh.stiffness_harmonics", fmt::format("{} harmonics", m.stiffness_harmonics.size()),
        "empty unless mesh.stiffness_source = \"harmonics\" (the other sources compute them)"});
  if (m.stiffness_source == StiffnessSource::kTable && m.stiffness_table.empty())
    return MaybeViolation(Violation{"mesh.stiffness_table", "\"\"",
                                    "a CSV file when mesh.stiffness_source = \"table\""});
  if (m.stiffness_harmonics.size() > static_cast<std::size_t>(HarmonicSeries::kMaxTerms))
    return bad("mesh.stiffness_harmonics", static_cast<double>(m.stiffness_harmonics.size()),
               fmt::format("at most {} harmonics", HarmonicSeries::kMaxTerms));
  double ratio_sum = 0.0;
  for (std::size_t i = 0; i < m.stiffness_harmonics.size(); ++i) {
    const StiffnessHarmonic& h = m.stiffness_harmonics[i];
    if (!(h.ratio >= 0 && h.ratio < 1))
      return bad(fmt::format("mesh.stiffness_harmonics[{}][0]", i), h.ratio,
                 "a ratio k_ai/k_m in [0, 1)");
    if (!std::isfinite(h.phase_deg))
      return bad(fmt::format("mesh.stiffness_harmonics[{}][1]", i), h.phase_deg,
                 "a finite phase in degrees");
    ratio_sum += h.ratio;
  }
  if (!(ratio_sum < 1) && m.stiffness_source == StiffnessSource::kHarmonics)
    return bad("mesh.stiffness_harmonics", ratio_sum,
               "harmonic ratios whose sum is < 1, so that k(t) stays positive");
  if (!(m.damping_ratio >= 0 && m.damping_ratio < 1))
    return bad("mesh.damping_ratio", m.damping_ratio, "a damping ratio in [0, 1)");

  const LoadData& l = c.load;
  if (!std::isfinite(l.torque_nm)) return bad("load.torque_nm", l.torque_nm, "a finite torque");
  if (!(l.fluctuation_ratio >= 0 && std::isfinite(l.fluctuation_ratio)))
    return bad("load.fluctuation_ratio", l.fluctuation_ratio, "a finite ratio F_a/F_m >= 0");
  if (!(l.fluctuation_order > 0 && std::isfinite(l.fluctuation_order)))
    return bad("load.fluctuation_order", l.fluctuation_order,
               "a finite order > 0 (torque frequency over shaft frequency)");
  if (!std::isfinite(l.fluctuation_phase_deg))
    return bad("load.fluctuation_phase_deg", l.fluctuation_phase_deg, "a finite phase");
  if (l.load_torque_nm && !std::isfinite(*l.load_torque_nm))
    return bad("load.load_torque_nm", *l.load_torque_nm, "a finite torque");

  if (!(c.speed.shaft_frequency_hz > 0 && std::isfinite(c.speed.shaft_frequency_hz)))
    return bad("speed.shaft_frequency_hz", c.speed.shaft_frequency_hz, "a finite frequency > 0 Hz");

  const SolverData& s = c.solver;
  if (!(s.duration_s > 0 && std::isfinite(s.duration_s)))
    return bad("solver.duration_s", s.duration_s, "a finite duration > 0 s");
  if (!(s.time_step_s >= 0 && s.time_step_s < s.duration_s))
    return bad("solver.time_step_s", s.time_step_s,
               fmt::format("0 (automatic) or a step > 0 s and smaller than solver.duration_s = {}",
                           s.duration_s));
  if (!(s.tolerance >= 1e-14 && s.tolerance <= 1e-3))
    return bad("solver.tolerance", s.tolerance, "a tolerance in [1e-14, 1e-3]");
  if (!(s.output_interval_s >= 0 && s.output_interval_s <= s.duration_s))
    return bad("solver.output_interval_s", s.output_interval_s,
               fmt::format("0 (automatic) or an interval > 0 s and at most solver.duration_s = {}",
                           s.duration_s));
  if (!(s.final_fraction > 0 && s.final_fraction < 1))
    return bad("solver.final_fraction", s.final_fraction, "a fraction in (0, 1)");
  return std::nullopt;
}

// Decodes a TOML table into a Case, remembering which keys it used so that any other key can be
// reported as unknown.
class Reader {
 public:
  Reader(const toml::table& root, std::string source, const std::vector<Override>& overrides)
      : root_(root), source_(std::move(source)), overrides_(overrides) {}

  void number(std::string_view section, std::string_view key, double& out) {
    if (const toml::node* n = find(section, key)) out = as_number(*n, section, key, "a number");
  }

  void optional_number(std::string_view section, std::string_view key, std::optional<double>& out) {
    if (const toml::node* n = find(section, key)) out = as_number(*n, section, key, "a number");
  }

  void number_pair(std::string_view section, std::string_view key, std::array<double, 2>& out) {
    if (const toml::node* n = find(section, key)) out = as_pair(*n, section, key);
  }

  void optional_number_pair(std::string_view section, std::string_view key,
                            std::optional<std::array<double, 2>>& out) {
    if (const toml::node* n = find(section, key)) out = as_pair(*n, section, key);
  }

  void integer(std::string_view section, std::string_view key, int& out) {
    const toml::node* n = find(section, key);
    if (!n) return;
    const auto* v = n->as_integer();
    if (!v || v->get() < -1000000000 || v->get() > 1000000000)
      fail(*n, section, key, "a whole number");
    out = static_cast<int>(v->get());
  }

  void text(std::string_view section, std::string_view key, std::string& out) {
    const toml::node* n = find(section, key);
    if (!n) return;
    if (!n->is_string()) fail(*n, section, key, "a string");
    out = *n->value<std::string>();
  }

  bool has(std::string_view section, std::string_view key) const {  // does not mark it known
    const toml::table* t = root_[section].as_table();
    return t && t->get(key) != nullptr;
  }

  void integer_pair(std::string_view section, std::string_view key, std::array<int, 2>& out) {
    const toml::node* n = find(section, key);
    if (!n) return;
    const toml::array* a = n->as_array();
    const char* allowed = "an array of two whole numbers, [z1, z2]";
    if (!a || a->size() != 2) fail(*n, section, key, allowed);
    for (std::size_t i = 0; i < 2; ++i) {
      const auto* v = (*a)[i].as_integer();
      if (!v) fail(*n, section, key, allowed);
      const std::int64_t z = v->get();
      if (z < -1000000 || z > 1000000) fail(*n, section, key, "teeth counts from 5 to 10000");
      out[i] = static_cast<int>(z);
    }
  }

  template <class Enum>
  void choice(std::string_view section, std::string_view key, Enum& out,
              std::initializer_list<std::pair<const char*, Enum>> options) {
    const toml::node* n = find(section, key);
    if (!n) return;
    std::string allowed;
    for (const auto& [name, value] : options) {
      allowed += allowed.empty() ? "" : " | ";
      allowed += fmt::format("\"{}\"", name);
    }
    const auto* s = n->as_string();
    if (s) {
      for (const auto& [name, value] : options) {
        if (s->get() == name) {
          out = value;
          return;
        }
      }
    }
    fail(*n, section, key, "one of " + allowed);
  }

  void harmonics(std::string_view section, std::string_view key,
                 std::vector<StiffnessHarmonic>& out) {
    const toml::node* n = find(section, key);
    if (!n) return;
    const char* allowed =
        "an array of [ratio k_ai/k_m, phase_deg] pairs, e.g. [[0.05, 0], [0.02, 90]]";
    const toml::array* a = n->as_array();
    if (!a) fail(*n, section, key, allowed);
    out.clear();
    for (const toml::node& item : *a) {
      const toml::array* pair = item.as_array();
      if (!pair || pair->size() != 2 || !(*pair)[0].is_number() || !(*pair)[1].is_number())
        fail(*n, section, key, allowed);
      out.push_back({*(*pair)[0].value<double>(), *(*pair)[1].value<double>()});
    }
  }

  void string(std::string_view key, std::string& out) {
    known_.try_emplace(std::string(key));
    const toml::node* n = root_.get(key);
    if (!n) return;
    used_.insert(std::string(key));
    if (!n->is_string()) fail(*n, "", key, "a string");
    out = *n->value<std::string>();
  }

  // Throws on the first key of the document that no reader call asked for. The reader calls
  // are the schema: every key asked for, present or not, is a known key.
  void reject_unknown() const {
    const std::map<std::string, std::vector<std::string>>& schema = known_;
    for (auto&& [k, node] : root_) {
      const std::string section(k.str());
      if (used_.count(section)) continue;
      auto it = schema.find(section);
      if (it == schema.end()) {
        std::string sections;
        for (const auto& [name, keys] : schema) sections += (sections.empty() ? "" : ", ") + name;
        throw InputError(fmt::format("{}: unknown key '{}'; allowed at the top level: {}",
                                     origin(section, k.source()), section, sections));
      }
      const toml::table* t = node.as_table();
      if (!t)
        throw InputError(fmt::format("{}: '{}' = {}: must be a table [{}]",
                                     origin(section, node.source()), section, node_text(node),
                                     section));
      for (auto&& [kk, child] : *t) {
        const std::string full = section + "." + std::string(kk.str());
        if (used_.count(full)) continue;
        std::string keys;
        for (const auto& name : it->second) keys += (keys.empty() ? "" : ", ") + name;
        throw InputError(fmt::format("{}: unknown key '{}'; allowed in [{}]: {}",
                                     origin(full, kk.source()), full, section, keys));
      }
    }
  }

  // The location of a dotted key, for range errors found after decoding.
  std::string location(const std::string& dotted) const {
    std::string path = dotted;
    while (!path.empty()) {
      toml::node_view<const toml::node> v = root_.at_path(path);
      if (v) return origin(dotted, v.node()->source());
      const auto cut = path.find_last_of(".[");
      if (cut == std::string::npos) break;
      path.resize(cut);
    }
    return source_ + " (default value)";
  }

 private:
  // Where the value of a dotted key came from: the last --set that wrote it or anything under
  // it, else the node's place in the file.
  std::string origin(const std::string& dotted, const toml::source_region& src) const {
    for (auto it = overrides_.rbegin(); it != overrides_.rend(); ++it) {
      const std::string& k = it->key;
      if (dotted == k || dotted.rfind(k + ".", 0) == 0 || dotted.rfind(k + "[", 0) == 0 ||
          k.rfind(dotted + ".", 0) == 0)
        return fmt::format("--set {}={}", it->key, it->value);
    }
    return where(src, source_);
  }

  const toml::node* find(std::string_view section, std::string_view key) {
    known_[std::string(section)].emplace_back(key);
    const toml::table* t = root_[section].as_table();
    if (!t) return nullptr;
    const toml::node* n = t->get(key);
    if (n) {
      const std::string full = fmt::format("{}.{}", section, key);
      used_.insert(full);
      origins_[full] = origin(full, n->source());
    }
    return n;
  }

 public:
  const std::map<std::string, std::string>& origins() const { return origins_; }

 private:
  [[noreturn]] void fail(const toml::node& n, std::string_view section, std::string_view key,
                         std::string_view allowed) const {
    const std::string full =
        section.empty() ? std::string(key) : fmt::format("{}.{}", section, key);
    throw InputError(fmt::format("{}: {} = {}: must be {}", origin(full, n.source()), full,
                                 node_text(n), allowed));
  }

  double as_number(const toml::node& n, std::string_view section, std::string_view key,
                   std::string_view allowed) const {
    if (!n.is_number()) fail(n, section, key, allowed);
    return *n.value<double>();
  }

  std::array<double, 2> as_pair(const toml::node& n, std::string_view section,
                                std::string_view key) const {
    const char* allowed = "an array of two numbers, [gear 1, gear 2]";
    const toml::array* a = n.as_array();
    if (!a || a->size() != 2 || !(*a)[0].is_number() || !(*a)[1].is_number())
      fail(n, section, key, allowed);
    return {*(*a)[0].value<double>(), *(*a)[1].value<double>()};
  }

  const toml::table& root_;
  std::string source_;
  const std::vector<Override>& overrides_;
  std::set<std::string> used_;
  std::map<std::string, std::string> origins_;
  std::map<std::string, std::vector<std::string>> known_;  // section -> keys, in reading order
};

// Copies every leaf of `from` into `into`, creating tables on the way (overrides).
void merge(toml::table& into, const toml::table& from) {
  for (auto&& [k, node] : from) {
    if (const toml::table* sub = node.as_table()) {
      toml::table* target = into[k].as_table();
      if (!target) {
        into.insert_or_assign(k, toml::table{});
        target = into[k].as_table();
      }
      merge(*target, *sub);
    } else {
      const toml::key& key = k;  // a structured binding cannot be captured portably
      node.visit([&](auto&& leaf) { into.insert_or_assign(key, leaf); });
    }
  }
}

// A bare word (`dopri5`, `clip`) as a TOML string; anything else as it is. TOML's own bare
// values (true, false, inf, nan) stay values.
std::string bare_text_quoted(const std::string& value) {
  if (value.empty() || value == "true" || value == "false" || value == "inf" || value == "nan")
    return value;
  const auto word = [](char ch) {
    return (ch >= 'a' && ch <= 'z') || (ch >= 'A' && ch <= 'Z') || ch == '_' || ch == '-';
  };
  if (!word(value.front()) || value.front() == '-') return value;
  for (char ch : value)
    if (!word(ch) && !(ch >= '0' && ch <= '9')) return value;
  return "\"" + value + "\"";
}

// Text toml++ 3.3 is known to mishandle (found by fuzzing it): a NUL byte (a debug assertion
// after '['), and a non-ASCII byte outside strings and comments (an unreachable branch for
// non-ASCII bare keys such as module_μm). TOML allows neither, so both are refused here, with
// where they are, before the text reaches toml++.
void guard_toml_text(const std::string& text, const std::string& source) {
  int line = 1, column = 0;
  enum class In { kCode, kComment, kBasic, kLiteral, kMultiBasic, kMultiLiteral } in = In::kCode;
  const auto starts = [&](std::size_t i, const char* token) {
    return text.compare(i, 3, token) == 0;
  };
  const auto fail = [&](const std::string& what) {
    throw InputError(fmt::format("{}:{}:{}: {}", source, line, column, what));
  };
  for (std::size_t i = 0; i < text.size(); ++i) {
    const auto ch = static_cast<unsigned char>(text[i]);
    ++column;
    if (ch == 0) fail("a NUL character, which TOML does not allow anywhere");
    if (ch == '\n') {
      ++line;
      column = 0;
      if (in == In::kComment || in == In::kBasic || in == In::kLiteral) in = In::kCode;
      continue;
    }
    switch (in) {
      case In::kCode:
        if (ch == '#') {
          in = In::kComment;
        } else if (starts(i, "\"\"\"")) {
          in = In::kMultiBasic;
          i += 2;
        } else if (starts(i, "'''")) {
          in = In::kMultiLiteral;
          i += 2;
        } else if (ch == '"') {
          in = In::kBasic;
        } else if (ch == '\'') {
          in = In::kLiteral;
        } else if (ch >= 0x80) {
          fail(
              "a non-ASCII character outside a string or a comment (TOML allows only A-Z, a-z, "
              "0-9, _ and - in bare keys: quote the key, or write the text as a string)");
        }
        break;
      case In::kBasic:
        if (ch == '\\')
          ++i;
        else if (ch == '"')
          in = In::kCode;
        break;
      case In::kLiteral:
        if (ch == '\'') in = In::kCode;
        break;
      case In::kMultiBasic:
        if (ch == '\\')
          ++i;
        else if (starts(i, "\"\"\"")) {
          in = In::kCode;
          i += 2;
        }
        break;
      case In::kMultiLiteral:
        if (starts(i, "'''")) {
          in = In::kCode;
          i += 2;
        }
        break;
      case In::kComment:
        break;
    }
  }
}

// toml::parse behind the guard.
toml::table parse_toml(const std::string& text, const std::string& source) {
  guard_toml_text(text, source);
  return toml::parse(text, source);
}

// An override of one element of an array, `key[i]` or `key[i][j]`: replaces that element of
// the array set in `root`. Throws InputError naming the override.
void set_element(toml::table& root, const Override& o, const std::string& origin) {
  const std::size_t open = o.key.find('[');
  const std::string base = o.key.substr(0, open);
  std::vector<std::size_t> index;
  for (std::size_t pos = open; pos < o.key.size();) {
    const std::size_t close = o.key.find(']', pos);
    const std::string digits =
        close == std::string::npos ? "" : o.key.substr(pos + 1, close - pos - 1);
    if (o.key[pos] != '[' || digits.empty() || digits.size() > 6 ||
        !std::all_of(digits.begin(), digits.end(), [](char ch) { return ch >= '0' && ch <= '9'; }))
      throw InputError(fmt::format(
          "{}: an element is addressed as key[i] or key[i][j], i and j integers from 0", origin));
    index.push_back(std::stoul(digits));
    pos = close + 1;
  }
  toml::node* node = root.at_path(base).node();
  if (!node || !node->is_array())
    throw InputError(fmt::format(
        "{}: {} is not an array set in this case; set the whole array first (e.g. --set "
        "'{}=[[0.05, 0]]')",
        origin, base, base));
  for (std::size_t k = 0; k < index.size(); ++k) {
    toml::array* arr = node ? node->as_array() : nullptr;
    if (!arr)
      throw InputError(
          fmt::format("{}: {} has no element [{}] (not an array there)", origin, base, index[k]));
    if (index[k] >= arr->size())
      throw InputError(fmt::format("{}: index {} is out of range: the array has {} element{}",
                                   origin, index[k], arr->size(), arr->size() == 1 ? "" : "s"));
    if (k + 1 < index.size()) {
      node = arr->get(index[k]);
      continue;
    }
    toml::table patch;
    try {
      patch = parse_toml("v = " + bare_text_quoted(o.value), origin);
    } catch (const toml::parse_error& e) {
      throw InputError(fmt::format("{}: not a valid TOML value ({})", origin, e.description()));
    }
    patch["v"].node()->visit([&](auto&& leaf) {
      arr->replace(arr->cbegin() + static_cast<std::ptrdiff_t>(index[k]), leaf);
    });
  }
}

Case decode(toml::table& root, const std::string& source, const std::vector<Override>& overrides,
            std::string name) {
  for (const Override& o : overrides) {
    const std::string origin = fmt::format("--set {}={}", o.key, o.value);
    if (o.key.find('[') != std::string::npos) {
      set_element(root, o, origin);
      continue;
    }
    toml::table patch;
    try {
      patch = parse_toml(o.key + " = " + bare_text_quoted(o.value), origin);
    } catch (const toml::parse_error& e) {
      throw InputError(
          fmt::format("{}: not a valid key and TOML value ({}); write e.g. "
                      "--set speed.shaft_frequency_hz=100 or --set mesh.tension=clip",
                      origin, e.description()));
    }
    merge(root, patch);
  }

  Case c;
  c.name = std::move(name);
  Reader r(root, source, overrides);
  r.string("description", c.description);
  ModelData& md = c.model;
  r.choice("model", "form", md.form,
           {{"gear_pair", ModelForm::kGearPair}, {"nondimensional", ModelForm::kNondimensional}});
  r.number("model", "zeta", md.zeta);
  r.number("model", "force_mean", md.force_mean);
  r.number("model", "force_alternating", md.force_alternating);
  r.number("model", "omega", md.omega);
  r.harmonics("model", "stiffness_harmonics", md.stiffness_harmonics);

  GearData& g = c.gear;
  r.number("gear", "normal_module_mm", g.normal_module_mm);
  r.number("gear", "normal_pressure_angle_deg", g.normal_pressure_angle_deg);
  r.number("gear", "helix_angle_deg", g.helix_angle_deg);
  r.number("gear", "center_distance_mm", g.center_distance_mm);
  r.integer_pair("gear", "teeth", g.teeth);
  r.number("gear", "face_width_mm", g.face_width_mm);
  r.number_pair("gear", "outside_diameter_mm", g.outside_diameter_mm);
  r.number_pair("gear", "profile_shift", g.profile_shift);
  r.number("gear", "density_kg_m3", g.density_kg_m3);
  r.number_pair("gear", "bore_diameter_mm", g.bore_diameter_mm);
  r.optional_number_pair("gear", "inertia_kg_m2", g.inertia_kg_m2);
  r.number_pair("gear", "youngs_modulus_gpa", g.youngs_modulus_gpa);
  r.number_pair("gear", "poisson_ratio", g.poisson_ratio);
  r.number_pair("gear", "basic_rack_dedendum", g.basic_rack_dedendum);
  r.number_pair("gear", "rim_thickness_mm", g.rim_thickness_mm);
  r.number_pair("gear", "web_thickness_mm", g.web_thickness_mm);

  MeshData& m = c.mesh;
  r.number("mesh", "backlash_um", m.backlash_um);
  r.number("mesh", "mean_stiffness_n_per_m", m.mean_stiffness_n_per_m);
  r.harmonics("mesh", "stiffness_harmonics", m.stiffness_harmonics);
  // Harmonics given without a source mean that those harmonics are wanted.
  if (r.has("mesh", "stiffness_harmonics") && !r.has("mesh", "stiffness_source"))
    m.stiffness_source = StiffnessSource::kHarmonics;
  r.choice("mesh", "stiffness_source", m.stiffness_source,
           {{"energy", StiffnessSource::kEnergy},
            {"harmonics", StiffnessSource::kHarmonics},
            {"table", StiffnessSource::kTable}});
  r.text("mesh", "stiffness_table", m.stiffness_table);
  r.integer("mesh", "harmonics_kept", m.harmonics_kept);
  r.integer("mesh", "stiffness_positions", m.stiffness_positions);
  r.integer("mesh", "stiffness_slices", m.stiffness_slices);
  r.number("mesh", "application_factor", m.application_factor);
  r.number("mesh", "damping_ratio", m.damping_ratio);
  r.choice("mesh", "damping", m.damping,
           {{"contact", DampingForm::kContact}, {"always", DampingForm::kAlways}});
  r.choice("mesh", "tension", m.tension,
           {{"allow", TensionRule::kAllow}, {"clip", TensionRule::kClip}});

  LoadData& l = c.load;
  r.number("load", "torque_nm", l.torque_nm);
  r.number("load", "fluctuation_ratio", l.fluctuation_ratio);
  r.number("load", "fluctuation_order", l.fluctuation_order);
  r.number("load", "fluctuation_phase_deg", l.fluctuation_phase_deg);
  r.optional_number("load", "load_torque_nm", l.load_torque_nm);

  r.number("speed", "shaft_frequency_hz", c.speed.shaft_frequency_hz);

  SolverData& s = c.solver;
  r.choice("solver", "method", s.method,
           {{"exact", Method::kExact}, {"newmark", Method::kNewmark}, {"dopri5", Method::kDopri5}});
  r.number("solver", "duration_s", s.duration_s);
  r.number("solver", "time_step_s", s.time_step_s);
  r.number("solver", "tolerance", s.tolerance);
  r.number("solver", "output_interval_s", s.output_interval_s);
  r.number("solver", "final_fraction", s.final_fraction);
  r.choice("solver", "initial", s.initial,
           {{"center", InitialCondition::kCenter}, {"static", InitialCondition::kStatic}});

  r.reject_unknown();

  if (MaybeViolation v = check_ranges(c)) {
    throw InputError(
        fmt::format("{}: {} = {}: must be {}", r.location(v->key), v->key, v->value, v->allowed));
  }
  c.origins = r.origins();
  return c;
}

}  // namespace

Override parse_override(const std::string& assignment) {
  const auto eq = assignment.find('=');
  if (eq == std::string::npos || eq == 0 || eq + 1 == assignment.size())
    throw InputError(fmt::format(
        "--set {}: must be key=value, e.g. --set speed.shaft_frequency_hz=100", assignment));
  auto trim = [](const std::string& s) {
    const auto b = s.find_first_not_of(" \t");
    const auto e = s.find_last_not_of(" \t");
    return b == std::string::npos ? std::string() : s.substr(b, e - b + 1);
  };
  return {trim(assignment.substr(0, eq)), trim(assignment.substr(eq + 1))};
}

Case parse_case(const std::string& toml_text, const std::string& source_name,
                const std::vector<Override>& overrides) {
  toml::table root;
  try {
    root = parse_toml(toml_text, source_name);
  } catch (const toml::parse_error& e) {
    throw InputError(
        fmt::format("{}: not valid TOML: {}", where(e.source(), source_name), e.description()));
  }
  return decode(root, source_name, overrides, "");
}

std::string read_input_file(const std::filesystem::path& path, const std::string& what) {
  std::error_code ec;
  const auto status = std::filesystem::status(path, ec);
  if (ec || !std::filesystem::exists(status))
    throw InputError(
        fmt::format("{}: cannot read the {} (missing or not readable)", path.string(), what));
  if (!std::filesystem::is_regular_file(status))
    throw InputError(
        fmt::format("{}: the {} must be a regular file, not a {}", path.string(), what,
                    std::filesystem::is_directory(status) ? "directory" : "device or pipe"));
  const std::uintmax_t size = std::filesystem::file_size(path, ec);
  if (ec || size > kMaxInputFileBytes)
    throw InputError(fmt::format("{}: the {} has {} bytes; at most {} are read", path.string(),
                                 what, ec ? 0 : size, kMaxInputFileBytes));
  std::ifstream in(path, std::ios::binary);
  if (!in)
    throw InputError(
        fmt::format("{}: cannot read the {} (missing or not readable)", path.string(), what));
  std::ostringstream text;
  text << in.rdbuf();
  if (in.bad())
    throw InputError(fmt::format("{}: error while reading the {}", path.string(), what));
  return text.str();
}

Case load_case(const std::optional<std::filesystem::path>& path,
               const std::vector<Override>& overrides) {
  if (!path) {
    toml::table empty;
    return decode(empty, "(defaults)", overrides, "default");
  }
  Case c = parse_case(read_input_file(*path, "case file"), path->string(), overrides);
  c.name = path->stem().string();
  c.directory = path->parent_path();
  return c;
}

void set_case_value(Case& c, const Override& o) {
  const std::string name = c.name;
  const std::filesystem::path directory = c.directory;
  std::map<std::string, std::string> origins = c.origins;
  c = parse_case(to_toml(c), "(case)", {o});
  c.name = name;
  c.directory = directory;
  // The keys came from where they came from before; the override from itself.
  const std::string base = o.key.substr(0, o.key.find('['));
  origins[base] = fmt::format("--set {}={}", o.key, o.value);
  c.origins = std::move(origins);
}

std::string with_origins(const Case& c, const std::string& message) {
  std::string from;
  for (const auto& [key, origin] : c.origins)
    if (message.find(key) != std::string::npos && message.find(origin) == std::string::npos)
      from += fmt::format("{}{} from {}", from.empty() ? "" : ", ", key, origin);
  return from.empty() ? message : fmt::format("{} ({})", message, from);
}

const char* to_string(Method m) {
  switch (m) {
    case Method::kExact:
      return "exact";
    case Method::kNewmark:
      return "newmark";
    case Method::kDopri5:
      return "dopri5";
  }
  return "?";
}

const char* to_string(ModelForm f) {
  return f == ModelForm::kGearPair ? "gear_pair" : "nondimensional";
}

std::string validate(const Case& c) {
  if (MaybeViolation v = check_ranges(c))
    return fmt::format("{} = {}: must be {}", v->key, v->value, v->allowed);
  return {};
}

namespace {

// TOML text of a value. Floats with the shortest digits that read back to the same double
// (154.98, not toml++'s 154.97999999999999), always with a point or an exponent so that they
// stay floats; strings as basic strings with JSON's escapes, which TOML shares.
void emit_value(std::string& out, const toml::node& v) {
  if (const auto* f = v.as_floating_point()) {
    const double x = f->get();
    if (std::isnan(x)) {
      out += "nan";
    } else if (std::isinf(x)) {
      out += x > 0 ? "inf" : "-inf";
    } else {
      std::string t = fmt::format("{}", x);
      if (t.find_first_of(".e") == std::string::npos) t += ".0";
      out += t;
    }
  } else if (const auto* i = v.as_integer()) {
    out += fmt::format("{}", i->get());
  } else if (const auto* b = v.as_boolean()) {
    out += b->get() ? "true" : "false";
  } else if (const auto* str = v.as_string()) {
    out += nlohmann::json(str->get()).dump();
  } else if (const auto* a = v.as_array()) {
    out += "[";
    for (std::size_t k = 0; k < a->size(); ++k) {
      out += k ? ", " : " ";
      emit_value(out, *a->get(k));
    }
    out += a->empty() ? "]" : " ]";
  }
}

// A key, bare when it can be (every key of a case can).
std::string emit_key(const std::string& key) {
  const bool bare = !key.empty() && std::all_of(key.begin(), key.end(), [](char ch) {
    return std::isalnum(static_cast<unsigned char>(ch)) || ch == '_' || ch == '-';
  });
  return bare ? key : nlohmann::json(key).dump();
}

// A case's table as TOML: its own values first, then each sub-table as a [section].
std::string emit_table(const toml::table& root) {
  std::string out;
  for (const auto& [key, node] : root)
    if (!node.is_table()) {
      out += emit_key(std::string(key.str())) + " = ";
      emit_value(out, node);
      out += "\n";
    }
  for (const auto& [key, node] : root)
    if (const auto* t = node.as_table()) {
      out += "\n[" + emit_key(std::string(key.str())) + "]\n";
      for (const auto& [k, v] : *t) {
        out += emit_key(std::string(k.str())) + " = ";
        emit_value(out, v);
        out += "\n";
      }
    }
  return out;
}

}  // namespace

std::string to_toml(const Case& c) {
  auto pair = [](const auto& a) { return toml::array{a[0], a[1]}; };
  toml::table gear{
      {"normal_module_mm", c.gear.normal_module_mm},
      {"normal_pressure_angle_deg", c.gear.normal_pressure_angle_deg},
      {"helix_angle_deg", c.gear.helix_angle_deg},
      {"center_distance_mm", c.gear.center_distance_mm},
      {"teeth", pair(c.gear.teeth)},
      {"face_width_mm", c.gear.face_width_mm},
      {"outside_diameter_mm", pair(c.gear.outside_diameter_mm)},
      {"profile_shift", pair(c.gear.profile_shift)},
      {"density_kg_m3", c.gear.density_kg_m3},
      {"bore_diameter_mm", pair(c.gear.bore_diameter_mm)},
      {"youngs_modulus_gpa", pair(c.gear.youngs_modulus_gpa)},
      {"poisson_ratio", pair(c.gear.poisson_ratio)},
      {"basic_rack_dedendum", pair(c.gear.basic_rack_dedendum)},
      {"rim_thickness_mm", pair(c.gear.rim_thickness_mm)},
      {"web_thickness_mm", pair(c.gear.web_thickness_mm)},
  };
  if (c.gear.inertia_kg_m2) gear.insert("inertia_kg_m2", pair(*c.gear.inertia_kg_m2));
  toml::array harmonics;
  for (const StiffnessHarmonic& h : c.mesh.stiffness_harmonics)
    harmonics.push_back(toml::array{h.ratio, h.phase_deg});
  const char* source = c.mesh.stiffness_source == StiffnessSource::kEnergy      ? "energy"
                       : c.mesh.stiffness_source == StiffnessSource::kHarmonics ? "harmonics"
                                                                                : "table";
  toml::table mesh{
      {"backlash_um", c.mesh.backlash_um},
      {"stiffness_source", source},
      {"mean_stiffness_n_per_m", c.mesh.mean_stiffness_n_per_m},
      {"stiffness_harmonics", harmonics},
      {"stiffness_table", c.mesh.stiffness_table},
      {"harmonics_kept", c.mesh.harmonics_kept},
      {"stiffness_positions", c.mesh.stiffness_positions},
      {"stiffness_slices", c.mesh.stiffness_slices},
      {"application_factor", c.mesh.application_factor},
      {"damping_ratio", c.mesh.damping_ratio},
      {"damping", c.mesh.damping == DampingForm::kContact ? "contact" : "always"},
      {"tension", c.mesh.tension == TensionRule::kAllow ? "allow" : "clip"},
  };
  toml::table load{
      {"torque_nm", c.load.torque_nm},
      {"fluctuation_ratio", c.load.fluctuation_ratio},
      {"fluctuation_order", c.load.fluctuation_order},
      {"fluctuation_phase_deg", c.load.fluctuation_phase_deg},
  };
  if (c.load.load_torque_nm) load.insert("load_torque_nm", *c.load.load_torque_nm);
  toml::table solver{
      {"method", to_string(c.solver.method)},
      {"duration_s", c.solver.duration_s},
      {"time_step_s", c.solver.time_step_s},
      {"tolerance", c.solver.tolerance},
      {"output_interval_s", c.solver.output_interval_s},
      {"final_fraction", c.solver.final_fraction},
      {"initial", c.solver.initial == InitialCondition::kCenter ? "center" : "static"},
  };
  toml::array model_harmonics;
  for (const StiffnessHarmonic& h : c.model.stiffness_harmonics)
    model_harmonics.push_back(toml::array{h.ratio, h.phase_deg});
  toml::table model{
      {"form", to_string(c.model.form)},  {"zeta", c.model.zeta},
      {"force_mean", c.model.force_mean}, {"force_alternating", c.model.force_alternating},
      {"omega", c.model.omega},           {"stiffness_harmonics", model_harmonics},
  };
  toml::table root{
      {"description", c.description},
      {"model", model},
      {"gear", gear},
      {"mesh", mesh},
      {"load", load},
      {"speed", toml::table{{"shaft_frequency_hz", c.speed.shaft_frequency_hz}}},
      {"solver", solver},
  };
  return emit_table(root);
}

}  // namespace geardyn
