#include "geardyn/case.hpp"

#include <fmt/format.h>
#include <toml++/toml.h>

#include <algorithm>
#include <cctype>
#include <charconv>
#include <cmath>
#include <fstream>
#include <map>
#include <set>
#include <sstream>
#include <type_traits>

#include "geardyn/case_keys.hpp"
#include "geardyn/harmonic_series.hpp"
#include "geardyn/suggest.hpp"
#include "geardyn/train_case.hpp"
#include "model/toml_source.hpp"

namespace geardyn {

// Where a node came from, for messages: "case.toml:12:5" or "--set mesh.backlash_um=-1".
std::string where(const toml::source_region& src, const std::string& fallback) {
  if (!src.path || src.path->empty()) return fallback;
  const std::string& path = *src.path;
  for (const char* prefix : kPositionlessSources)
    if (path.rfind(prefix, 0) == 0) return path;
  if (src.begin.line == 0) return path;
  return fmt::format("{}:{}:{}", path, src.begin.line, src.begin.column);
}

std::string origin_of(const std::vector<Override>& overrides, const std::string& dotted,
                      const toml::source_region& src, const std::string& source) {
  for (auto it = overrides.rbegin(); it != overrides.rend(); ++it) {
    const std::string& k = it->key;
    // The key itself, a key or an entry under it, or an entry of it (key[i][j]): an array
    // with an entry overridden is the override's.
    if (dotted == k || dotted.rfind(k + ".", 0) == 0 || dotted.rfind(k + "[", 0) == 0 ||
        k.rfind(dotted + ".", 0) == 0 || k.rfind(dotted + "[", 0) == 0)
      return it->label();
  }
  return where(src, source);
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
  return printable(out.str());
}

std::string printable(std::string_view text) {
  std::string out;
  for (const char ch : text) {
    const auto c = static_cast<unsigned char>(ch);
    if (ch == '\n') {
      out += "\\n";
    } else if (ch == '\t') {
      out += "\\t";
    } else if (ch == '\r') {
      out += "\\r";
    } else if (c < 0x20 || c == 0x7f) {
      out += fmt::format("\\u{:04X}", c);
    } else {
      out += ch;
    }
  }
  return out;
}

namespace {

std::string format_number(double x) { return fmt::format("{}", x); }

// A broken bound found in a decoded case: the dotted key (with [i] for array elements), the value
// as text, and what is allowed.
struct Violation {
  std::string key;
  std::string value;
  std::string allowed;
};

using MaybeViolation = std::optional<Violation>;

MaybeViolation violation(std::string key, double v, std::string allowed) {
  return Violation{std::move(key), format_number(v), std::move(allowed)};
}

// A value of key `k` outside its bounds (case_keys.hpp), by the kind of the key. Conditions are
// written so that NaN fails them.
class KeyCheck {
 public:
  KeyCheck(const CaseKey& k, const Case& c) : k_(k), c_(const_cast<Case&>(c)) {}

  MaybeViolation operator()(NumberField f) const { return number(f(c_)); }
  MaybeViolation operator()(OptionalNumberField f) const {
    return f(c_) ? number(*f(c_)) : std::nullopt;
  }
  MaybeViolation operator()(IntegerField f) const { return number(f(c_)); }
  MaybeViolation operator()(PairField f) const { return pair(f(c_)); }
  MaybeViolation operator()(OptionalPairField f) const {
    return f(c_) ? pair(*f(c_)) : std::nullopt;
  }
  MaybeViolation operator()(IntegerPairField f) const { return pair(f(c_)); }
  MaybeViolation operator()(HarmonicsField f) const {
    return terms(f(c_), HarmonicSeries::kMaxTerms);
  }
  MaybeViolation operator()(ErrorHarmonicsField f) const {
    return terms(f(c_), kMaxErrorHarmonics);
  }
  MaybeViolation operator()(TextField) const { return std::nullopt; }
  MaybeViolation operator()(const ChoiceField&) const { return std::nullopt; }

 private:
  std::string element(std::size_t i) const { return fmt::format("{}[{}]", k_.name, i); }
  // [value, phase_deg] pairs: at most `most` of them, each value in the key's range.
  template <class Term>
  MaybeViolation terms(const std::vector<Term>& h, int most) const {
    if (h.size() > static_cast<std::size_t>(most))
      return violation(std::string(k_.name), static_cast<double>(h.size()),
                       fmt::format("at most {} harmonics", most));
    for (std::size_t i = 0; i < h.size(); ++i) {
      const auto& [value, phase_deg] = h[i];
      if (!k_.range.contains(value)) return violation(element(i) + "[0]", value, k_.allowed());
      if (!std::isfinite(phase_deg))
        return violation(element(i) + "[1]", phase_deg, "a finite phase in degrees");
    }
    return std::nullopt;
  }
  MaybeViolation number(double v) const {
    if (k_.range.contains(v)) return std::nullopt;
    return violation(std::string(k_.name), v, k_.allowed());
  }
  template <class T>
  MaybeViolation pair(const std::array<T, 2>& v) const {
    for (std::size_t i = 0; i < 2; ++i)
      if (!k_.range.contains(v[i])) return violation(element(i), v[i], k_.allowed());
    return std::nullopt;
  }

  const CaseKey& k_;
  Case& c_;  // the accessors take a Case&; only read here
};

// The rules that tie keys together, beside the table's bounds of each key.
MaybeViolation check_relations(const Case& c) {
  auto bad = [](std::string key, double v, std::string allowed) {
    return MaybeViolation(Violation{std::move(key), format_number(v), std::move(allowed)});
  };
  double kappa_sum = 0;
  for (const StiffnessHarmonic& h : c.model.stiffness_harmonics) kappa_sum += h.ratio;
  if (!(kappa_sum < 1))
    return bad("model.stiffness_harmonics", kappa_sum, "ratios whose sum is < 1 (k stays > 0)");

  const MeshData& m = c.mesh;
  if (m.stiffness_source == StiffnessSource::kHarmonics && !(m.mean_stiffness_n_per_m > 0))
    return bad("mesh.mean_stiffness_n_per_m", m.mean_stiffness_n_per_m,
               "a finite stiffness > 0 N/m with mesh.stiffness_source = \"harmonics\"");
  if (m.harmonics_kept >= m.stiffness_positions / 2)
    return bad("mesh.harmonics_kept", m.harmonics_kept,
               "fewer than half of mesh.stiffness_positions");
  const bool given_harmonics = m.stiffness_source == StiffnessSource::kHarmonics ||
                               m.stiffness_source == StiffnessSource::kIso6336;
  if (!given_harmonics && !m.stiffness_harmonics.empty())
    return MaybeViolation(Violation{
        "mesh.stiffness_harmonics", fmt::format("{} harmonics", m.stiffness_harmonics.size()),
        "empty unless mesh.stiffness_source = \"harmonics\" or \"iso6336\" (the other sources "
        "compute them)"});
  if (m.stiffness_source == StiffnessSource::kTable && m.stiffness_table.empty())
    return MaybeViolation(Violation{"mesh.stiffness_table", "\"\"",
                                    "a CSV file when mesh.stiffness_source = \"table\""});
  double ratio_sum = 0.0;
  for (const StiffnessHarmonic& h : m.stiffness_harmonics) ratio_sum += h.ratio;
  if (!(ratio_sum < 1) && given_harmonics)
    return bad("mesh.stiffness_harmonics", ratio_sum,
               "harmonic ratios whose sum is < 1, so that k(t) stays positive");

  if (!m.transmission_error_um.empty() && !m.transmission_error_table.empty())
    return MaybeViolation(Violation{
        "mesh.transmission_error_table", fmt::format("\"{}\"", m.transmission_error_table),
        "empty when mesh.transmission_error_um gives the harmonics (one or the other)"});

  if (c.load.load_fluctuation_nm != 0 && !c.load.load_torque_nm)
    return bad("load.load_fluctuation_nm", c.load.load_fluctuation_nm,
               "0 unless load.load_torque_nm is given (the matched load follows T1(t) already)");
  if (c.model.dof != 3 && c.model.dof != 6 && c.model.dof != 12)
    return bad("model.dof", c.model.dof, "3, 6 or 12");
  for (int i = 0; i < 2; ++i)
    if (c.shafts.end_inertia_kg_m2[i] > 0 && c.model.form != ModelForm::kCoupled)
      return bad(fmt::format("shafts.end_inertia_kg_m2[{}]", i), c.shafts.end_inertia_kg_m2[i],
                 "0 unless model.form = \"coupled\" (the one-degree forms have no shafts)");

  const SolverData& s = c.solver;
  if (!(s.time_step_s < s.duration_s))
    return bad("solver.time_step_s", s.time_step_s,
               fmt::format("0 (automatic) or a step > 0 s and smaller than solver.duration_s = {}",
                           s.duration_s));
  if (!(s.output_interval_s <= s.duration_s))
    return bad("solver.output_interval_s", s.output_interval_s,
               fmt::format("0 (automatic) or an interval > 0 s and at most solver.duration_s = {}",
                           s.duration_s));
  return std::nullopt;
}

// Every bound of every key, then the relations; the first broken one.
MaybeViolation check_ranges(const Case& c) {
  for (const CaseKey& k : case_keys())
    if (MaybeViolation v = std::visit(KeyCheck(k, c), k.field)) return v;
  return check_relations(c);
}

// The source name of a case made of the defaults alone.
constexpr const char* kDefaultsSource = "(defaults)";

// The case keys `message` names, as whole words (gear.teeth in "gear.teeth[0] = 3"), in the
// order it names them, each once.
std::vector<const CaseKey*> keys_named(const std::string& message) {
  const auto word = [](char ch) {
    return std::isalnum(static_cast<unsigned char>(ch)) != 0 || ch == '_' || ch == '.';
  };
  std::vector<std::pair<std::size_t, const CaseKey*>> found;
  for (const CaseKey& k : case_keys()) {
    if (k.section().empty()) continue;
    for (std::size_t at = message.find(k.name); at != std::string::npos;
         at = message.find(k.name, at + 1)) {
      const std::size_t end = at + k.name.size();
      if ((at == 0 || !word(message[at - 1])) && (end == message.size() || !word(message[end]))) {
        found.emplace_back(at, &k);
        break;
      }
    }
  }
  std::sort(found.begin(), found.end(),
            [](const auto& a, const auto& b) { return a.first < b.first; });
  std::vector<const CaseKey*> out;
  out.reserve(found.size());
  for (const auto& [at, k] : found) out.push_back(k);
  return out;
}

}  // namespace

std::string annotate_origins(const Case& c, const std::map<std::string, std::string>& origins,
                             const std::string& message) {
  const std::vector<const CaseKey*> named = keys_named(message);
  const auto given = [&](const CaseKey* k) { return origins.count(std::string(k->name)) > 0; };
  const auto value = [&](const CaseKey* k) {
    return fmt::format("{} = {} ({})", k->name, k->value_text(c), origins.at(std::string(k->name)));
  };
  // A message about a key at its default (its subject, named first) is true because of keys the
  // user gave: those it names, else those given in the subject's section (a module of
  // nanometres makes the default outside diameter a point). It starts with them.
  std::string cause;
  if (!named.empty() && !given(named.front())) {
    for (const CaseKey* k : named)
      if (given(k)) cause += (cause.empty() ? "" : ", ") + value(k);
    if (cause.empty())
      for (const auto& [key, origin] : origins)
        if (const CaseKey* k = find_case_key(key); k && k->section() == named.front()->section())
          cause += (cause.empty() ? "" : ", ") + value(k);
  }
  const std::string out = cause.empty() ? message : fmt::format("with {}: {}", cause, message);
  // Then where every key it names came from, unless it says so already.
  std::string from;
  for (const CaseKey* k : named) {
    const auto it = origins.find(std::string(k->name));
    if (it != origins.end() && out.find(it->second) != std::string::npos) continue;
    from += fmt::format("{}{}{}", from.empty() ? "" : ", ", k->name,
                        it != origins.end() ? " from " + it->second : ": default value");
  }
  return from.empty() ? out : fmt::format("{} ({})", out, from);
}

namespace {

// Decodes a TOML table into a Case, remembering which keys it used so that any other key can be
// reported as unknown.
class Reader {
 public:
  // `known`: where each key of a case read again came from (Case::origins, set_case_value),
  // in place of the places in the text written out for it; a key not in it is at its default.
  Reader(const toml::table& root, std::string source, const std::vector<Override>& overrides,
         const std::map<std::string, std::string>* known = nullptr)
      : root_(root), source_(std::move(source)), overrides_(overrides), known_origins_(known) {}

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

  // A top-level table read by another reader (the train's elements): known as a whole.
  const toml::node* claim(const std::string& section) {
    known_[section];
    used_.insert(section);
    return root_.get(section);
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

  void choice(std::string_view section, std::string_view key, Case& c, const ChoiceField& f) {
    const toml::node* n = find(section, key);
    if (!n) return;
    std::string allowed;
    for (const auto& [name, value] : f.options)
      allowed += fmt::format("{}\"{}\"", allowed.empty() ? "" : " | ", name);
    if (const auto* s = n->as_string()) {
      for (const auto& [name, value] : f.options) {
        if (s->get() == name) {
          f.set(c, value);
          return;
        }
      }
    }
    fail(*n, section, key, "one of " + allowed);
  }

  template <class Term>
  void harmonics(std::string_view section, std::string_view key, std::vector<Term>& out) {
    const toml::node* n = find(section, key);
    if (!n) return;
    const char* allowed =
        std::is_same_v<Term, StiffnessHarmonic>
            ? "an array of [ratio k_ai/k_m, phase_deg] pairs, e.g. [[0.05, 0], [0.02, 90]]"
            : "an array of [amplitude, phase_deg] pairs, e.g. [[0.5, 0], [0.1, 90]]";
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

  // Reads key `k` into `c` when the document has it, by the kind of the key.
  void read(const CaseKey& k, Case& c) {
    const std::string_view section = k.section(), key = k.leaf();
    if (section.empty()) {
      string(key, std::get<TextField>(k.field)(c));
      return;
    }
    struct Read {
      void operator()(NumberField f) const { r.number(section, key, f(c)); }
      void operator()(OptionalNumberField f) const { r.optional_number(section, key, f(c)); }
      void operator()(IntegerField f) const { r.integer(section, key, f(c)); }
      void operator()(PairField f) const { r.number_pair(section, key, f(c)); }
      void operator()(OptionalPairField f) const { r.optional_number_pair(section, key, f(c)); }
      void operator()(IntegerPairField f) const { r.integer_pair(section, key, f(c)); }
      void operator()(HarmonicsField f) const { r.harmonics(section, key, f(c)); }
      void operator()(ErrorHarmonicsField f) const { r.harmonics(section, key, f(c)); }
      void operator()(TextField f) const { r.text(section, key, f(c)); }
      void operator()(const ChoiceField& f) const { r.choice(section, key, c, f); }
      Reader& r;
      Case& c;
      std::string_view section, key;
    };
    std::visit(Read{*this, c, section, key}, k.field);
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
        std::vector<std::string> names;
        names.reserve(schema.size());
        for (const auto& [name, keys] : schema) names.push_back(name);
        throw InputError(fmt::format("{}: unknown key '{}'{}; allowed at the top level: {}",
                                     origin(section, k.source()).value_or("default value"), section,
                                     did_you_mean(section, names), sections));
      }
      const toml::table* t = node.as_table();
      if (!t)
        throw InputError(fmt::format("{}: '{}' = {}: must be a table [{}]",
                                     origin(section, node.source()).value_or("default value"),
                                     section, node_text(node), section));
      for (auto&& [kk, child] : *t) {
        const std::string full = section + "." + std::string(kk.str());
        if (used_.count(full)) continue;
        std::string keys;
        for (const auto& name : it->second) keys += (keys.empty() ? "" : ", ") + name;
        throw InputError(fmt::format("{}: unknown key '{}'{}; allowed in [{}]: {}",
                                     origin(full, kk.source()).value_or("default value"), full,
                                     did_you_mean(kk.str(), it->second), section, keys));
      }
    }
  }

  // The location of a dotted key, for range errors found after decoding.
  std::string location(const std::string& dotted) const {
    // The key's own node, or the array it is an element of ("key[1]" of a key given whole);
    // never its section, which a --set of another key may have made.
    std::string path = dotted;
    while (!path.empty()) {
      toml::node_view<const toml::node> v = root_.at_path(path);
      if (v) return origin(dotted, v.node()->source()).value_or("default value");
      const auto cut = path.find_last_of('[');
      if (cut == std::string::npos) break;
      path.resize(cut);
    }
    return source_ == kDefaultsSource ? std::string("default value")
                                      : fmt::format("default value (not in {})", source_);
  }

 private:
  // Where the value of a dotted key came from: the last --set that wrote it or anything under
  // it, else the node's place in the file; for a case read again, where it came from before
  // (nullopt: a default written out).
  std::optional<std::string> origin(const std::string& dotted,
                                    const toml::source_region& src) const {
    if (!known_origins_) return origin_of(overrides_, dotted, src, source_);
    if (std::string o = origin_of(overrides_, dotted, {}, ""); !o.empty()) return o;
    const auto it = known_origins_->find(dotted);
    if (it == known_origins_->end()) return std::nullopt;
    return it->second;
  }

  const toml::node* find(std::string_view section, std::string_view key) {
    known_[std::string(section)].emplace_back(key);
    const toml::table* t = root_[section].as_table();
    if (!t) return nullptr;
    const toml::node* n = t->get(key);
    if (n) {
      const std::string full = fmt::format("{}.{}", section, key);
      used_.insert(full);
      if (std::optional<std::string> o = origin(full, n->source())) origins_[full] = *o;
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
    throw InputError(fmt::format("{}: {} = {}: must be {}",
                                 origin(full, n.source()).value_or("default value"), full,
                                 node_text(n), allowed));
  }

  double as_number(const toml::node& n, std::string_view section, std::string_view key,
                   std::string_view allowed) const {
    if (!n.is_number()) fail(n, section, key, allowed);
    return *n.value<double>();
  }

  std::array<double, 2> as_pair(const toml::node& n, std::string_view section,
                                std::string_view key) const {
    const char* allowed = "a number for both gears, or an array of two, [gear 1, gear 2]";
    if (n.is_number()) return {*n.value<double>(), *n.value<double>()};
    const toml::array* a = n.as_array();
    if (!a || a->size() != 2 || !(*a)[0].is_number() || !(*a)[1].is_number())
      fail(n, section, key, allowed);
    return {*(*a)[0].value<double>(), *(*a)[1].value<double>()};
  }

  const toml::table& root_;
  std::string source_;
  const std::vector<Override>& overrides_;
  const std::map<std::string, std::string>* known_origins_;
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

// A bare word or file name (`dopri5`, `clip`, `te.csv`, `tables/k.csv`) as a TOML string;
// anything else as it is. TOML's own bare values (true, false, inf, nan) stay values.
std::string bare_text_quoted(const std::string& value) {
  if (value.empty() || value == "true" || value == "false" || value == "inf" || value == "nan")
    return value;
  const auto letter = [](char ch) { return (ch >= 'a' && ch <= 'z') || (ch >= 'A' && ch <= 'Z'); };
  const auto word = [&](char ch) {
    return letter(ch) || (ch >= '0' && ch <= '9') || ch == '_' || ch == '-' || ch == '.' ||
           ch == '/';
  };
  if (!letter(value.front()) && value.front() != '_') return value;
  for (char ch : value)
    if (!word(ch)) return value;
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

}  // namespace

// toml::parse behind the guard. A UTF-8 byte-order mark (as Windows editors write one) is no
// part of the document.
toml::table parse_toml(const std::string& text, const std::string& source) {
  const std::string_view body = without_byte_order_mark(text);
  const std::string document(body);
  guard_toml_text(document, source);
  return toml::parse(document, source);
}

namespace {

// An override of one element of an array, `key[i]` or `key[i][j]`: replaces that element of
// the array set in `root`. Throws InputError naming the override.
void set_element(toml::table& root, const Override& o, const std::string& given) {
  // Where the value came from and the key it sets, once ("--from 10: key[1][0]").
  const std::string origin =
      given.find(o.key) == std::string::npos ? fmt::format("{}: {}", given, o.key) : given;
  const std::size_t open = o.key.find('[');
  const std::string base = o.key.substr(0, open);
  std::vector<std::size_t> index;
  // A key of a table in an array of tables: train.mesh[1].backlash_um.
  std::string member;
  for (std::size_t pos = open; pos < o.key.size();) {
    if (o.key[pos] == '.' && !index.empty()) {
      member = o.key.substr(pos + 1);
      break;
    }
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
  // An element's key where the case writes no such element (a planetary preset's elements are
  // set through the preset's keys).
  if ((!node || !node->is_array()) && !member.empty())
    throw InputError(fmt::format(
        "{}: the case writes no [[{}]] table{}", origin, base,
        root.at_path("train.planetary").is_array()
            ? " (the elements its [[train.planetary]] writes are set through the preset's keys, "
              "train.planetary[0].<key>: `geardyn keys` lists them)"
            : ""));
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
    if (!member.empty()) {
      toml::table* element = arr->get(index[k])->as_table();
      // An entry of an array in that table: train.speed[0].acceleration_harmonics[0][0].
      if (element && member.find('.') == std::string::npos &&
          member.find('[') != std::string::npos) {
        Override inner = o;
        inner.key = member;
        set_element(*element, inner, origin);
        return;
      }
      if (!element || member.find_first_of(".[") != std::string::npos)
        throw InputError(fmt::format(
            "{}: {}[{}] is no table of keys; write e.g. --set train.mesh[0].backlash_um=50", origin,
            base, index[k]));
      toml::table patch;
      try {
        patch = parse_toml(member + " = " + bare_text_quoted(o.value), origin);
      } catch (const toml::parse_error& e) {
        throw InputError(fmt::format("{}: not a valid TOML value ({})", origin, e.description()));
      }
      for (auto&& [k2, v] : patch)
        v.visit([&, &name = k2](auto&& leaf) { element->insert_or_assign(name, leaf); });
      return;
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

// A dotted key that runs through an array of the case (`train.torque.0.mean_nm`,
// `train.torque.mean_nm`), which TOML would read as a table in the array's place: refused, with
// the element's address (`train.torque[0].mean_nm`, set_element). Keys that do not reach an
// array are left to TOML.
void refuse_key_through_array(const toml::table& root, const Override& o,
                              const std::string& origin) {
  const toml::node* node = nullptr;
  const toml::table* table = &root;
  for (std::size_t pos = 0; table != nullptr;) {
    const std::size_t dot = o.key.find('.', pos);
    if (dot == std::string::npos) return;  // the key itself: a whole array may be replaced
    node = table->get(o.key.substr(pos, dot - pos));
    if (node == nullptr) return;
    if (const toml::array* array = node->as_array()) {
      const std::string prefix = o.key.substr(0, dot), rest = o.key.substr(dot + 1);
      const std::string next = rest.substr(0, rest.find('.'));
      const bool index =
          !next.empty() && next.size() <= 6 &&
          std::all_of(next.begin(), next.end(), [](char ch) { return ch >= '0' && ch <= '9'; });
      const std::string address =
          index ? fmt::format("{}[{}]{}", prefix, next, rest.substr(next.size()))
                : fmt::format("{}[0].{}", prefix, rest);
      throw InputError(fmt::format(
          "{}: {} is an array{}, whose elements --set addresses by index, from 0: write {}", origin,
          prefix, array->is_array_of_tables() ? fmt::format(" of tables ([[{}]])", prefix) : "",
          address));
    }
    table = node->as_table();
    pos = dot + 1;
  }
}

Case decode(toml::table& root, const std::string& source, const std::vector<Override>& overrides,
            std::string name, const std::map<std::string, std::string>* known = nullptr) {
  for (const Override& o : overrides) {
    const std::string origin = o.label();
    if (o.key.find('[') != std::string::npos) {
      set_element(root, o, origin);
      continue;
    }
    refuse_key_through_array(root, o, origin);
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
  Reader r(root, source, overrides, known);
  for (const CaseKey& k : case_keys()) r.read(k, c);
  // Harmonics given without a source mean that those harmonics are wanted.
  if (r.has("mesh", "stiffness_harmonics") && !r.has("mesh", "stiffness_source"))
    c.mesh.stiffness_source = StiffnessSource::kHarmonics;
  const std::map<std::string, std::string>& given = r.origins();
  const auto form_origin = [&] {
    const auto it = given.find("model.form");
    return it == given.end() ? std::string("default value") : it->second;
  };
  if (const toml::node* train = r.claim("train")) {
    if (c.model.form != ModelForm::kTrain)
      throw InputError(fmt::format(
          "{}: [train] is read with model.form = \"train\"; this case has model.form = \"{}\" "
          "({}): set model.form = \"train\" or remove [train]",
          where(train->source(), source), to_string(c.model.form), form_origin()));
    c.train = std::make_shared<const TrainCase>(read_train_case(*train, source, overrides));
  }

  // Unknown keys first: a misspelt [train] is named as the key it is.
  r.reject_unknown();
  if (c.model.form == ModelForm::kTrain && !c.train)
    throw InputError(fmt::format(
        "{}: model.form = \"train\" needs a [train] section: its reference_speed_hz and "
        "[[train.body]], [[train.mesh]] tables (docs/case-files.md, \"Gear trains\")",
        form_origin()));

  if (MaybeViolation v = check_ranges(c)) {
    // The bound may name other keys (a step below solver.duration_s): where each came from.
    throw InputError(annotate_origins(
        c, r.origins(),
        fmt::format("{}: {} = {}: must be {}", r.location(v->key), v->key, v->value, v->allowed)));
  }
  c.origins = r.origins();
  return c;
}

}  // namespace

std::string_view without_byte_order_mark(std::string_view text) {
  constexpr std::string_view kBom = "\xEF\xBB\xBF";
  return text.substr(0, kBom.size()) == kBom ? text.substr(kBom.size()) : text;
}

std::string Override::label() const {
  return origin.empty() ? fmt::format("--set {}={}", key, value) : origin;
}

Override parse_override(const std::string& assignment) {
  // A control character (a newline pasted into the shell's quotes) is no part of a one-line
  // key=value: said here, shown escaped, before any TOML reads it.
  const auto control = std::find_if(assignment.begin(), assignment.end(), [](char ch) {
    const auto c = static_cast<unsigned char>(ch);
    return ch != '\t' && (c < 0x20 || c == 0x7f);
  });
  if (control != assignment.end())
    throw InputError(fmt::format(
        "--set {}: holds the control character {} at character {}: a --set is one line, "
        "key=value (write a newline inside a TOML string as \\n)",
        printable(assignment), printable(std::string(1, *control)),
        control - assignment.begin() + 1));
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
  return std::string(without_byte_order_mark(text.str()));
}

Case load_case(const std::optional<std::filesystem::path>& path,
               const std::vector<Override>& overrides) {
  if (!path) {
    toml::table empty;
    return decode(empty, kDefaultsSource, overrides, "default");
  }
  Case c = parse_case(read_input_file(*path, "case file"), path->string(), overrides);
  c.name = path->stem().string();
  c.directory = path->parent_path();
  return c;
}

namespace {
// A real number a study may vary, within its key's range, set in place: what decoding the case
// again with the override gives (case_keys_test checks it for every such key), without the
// round trip through TOML, which costs a sweep point more than its integration. False when
// the override is anything else (the slow path then decodes it, with its messages).
bool set_number_in_place(Case& c, const Override& o) {
  const std::size_t open = o.key.find('[');
  const CaseKey* k = find_case_key(o.key);
  if (k == nullptr || !k->sweepable) return false;
  int index = -1;
  if (open != std::string::npos) {
    const std::string_view rest = std::string_view(o.key).substr(open);
    if (rest != "[0]" && rest != "[1]") return false;
    index = rest[1] - '0';
  }
  double v = 0;
  const char* end = o.value.data() + o.value.size();
  const auto [ptr, ec] = std::from_chars(o.value.data(), end, v);
  if (ec != std::errc{} || ptr != end || !std::isfinite(v) || !k->range.contains(v)) return false;
  // Set, and kept only if the rules tying keys together still hold (check_relations).
  const auto kept = [&c](auto& slot, auto value) {
    const auto before = slot;
    slot = value;
    if (!check_relations(c)) return true;
    slot = before;
    return false;
  };
  if (const auto* f = std::get_if<NumberField>(&k->field); f && index < 0) return kept((*f)(c), v);
  if (const auto* f = std::get_if<OptionalNumberField>(&k->field); f && index < 0)
    return kept((*f)(c), std::optional<double>(v));
  if (const auto* f = std::get_if<PairField>(&k->field); f && index >= 0)
    return kept((*f)(c)[static_cast<std::size_t>(index)], v);
  return false;
}
}  // namespace

void set_case_value(Case& c, const Override& o) {
  const std::string base = o.key.substr(0, o.key.find('['));
  if (set_number_in_place(c, o)) {
    c.origins[base] = o.label();
    return;
  }
  if (c.train) {
    TrainCase t = *c.train;
    if (set_train_number_in_place(t, o)) {
      c.train = std::make_shared<const TrainCase>(std::move(t));
      c.origins[base] = o.label();
      return;
    }
  }
  const std::string name = c.name;
  const std::filesystem::path directory = c.directory;
  std::map<std::string, std::string> origins = c.origins;
  const std::shared_ptr<const TrainCase> train = c.train;
  // Read again from its text, each key's origin where it came from before (a message that names
  // another key cites the user's file or --set, never this text).
  toml::table root = parse_toml(to_toml(c), "(case)");
  c = decode(root, "(case)", {o}, "", &origins);
  c.name = name;
  c.directory = directory;
  // The keys came from where they came from before; the override from itself.
  origins[base] = o.label();
  c.origins = std::move(origins);
  if (train && c.train) {
    // The train's elements and keys too: read again from the text written here (every key,
    // the defaults written out), each would cite its place in that text ("(case):12:3"), not
    // the user's file or --set; a default has no place.
    TrainCase t = *c.train;
    std::map<std::string, std::string> kept;
    for (const auto& [label, where] : t.origins) {
      if (where == o.label())
        kept[label] = where;
      else if (const auto it = train->origins.find(label); it != train->origins.end())
        kept[label] = it->second;
    }
    t.origins = std::move(kept);
    c.train = std::make_shared<const TrainCase>(std::move(t));
  }
}

std::string with_origins(const Case& c, const std::string& message) {
  return annotate_origins(c, c.origins, message);
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
  switch (f) {
    case ModelForm::kGearPair:
      return "gear_pair";
    case ModelForm::kNondimensional:
      return "nondimensional";
    case ModelForm::kCoupled:
      return "coupled";
    case ModelForm::kTrain:
      return "train";
  }
  return "?";
}

std::string validate(const Case& c) {
  if (MaybeViolation v = check_ranges(c))
    return fmt::format("{} = {}: must be {}", v->key, v->value, v->allowed);
  return {};
}

std::string to_toml(const Case& c) {
  std::string top, sections;
  std::string_view section;
  for (const CaseKey& k : case_keys()) {
    if (k.optional() && k.value_text(c) == "absent") continue;
    // A method not given is chosen per case (a train's default may take dopri5): written, it
    // would read as asked for.
    if (k.name == "solver.method" && c.origins.count("solver.method") == 0) continue;
    std::string& out = k.section().empty() ? top : sections;
    if (!k.section().empty() && k.section() != section) {
      section = k.section();
      out += fmt::format("\n[{}]\n", section);
    }
    out += fmt::format("{} = {}\n", k.leaf(), k.value_text(c));
  }
  if (c.train) sections += train_toml(*c.train);
  return top + sections;
}

}  // namespace geardyn
