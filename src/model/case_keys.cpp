#include "geardyn/case_keys.hpp"

#include <fmt/format.h>

#include <charconv>
#include <cmath>
#include <map>
#include <nlohmann/json.hpp>

#include "geardyn/harmonic_series.hpp"
#include "geardyn/train_case.hpp"

namespace geardyn {
namespace {

constexpr double kInf = std::numeric_limits<double>::infinity();
// The smallest half backlash accepted, um: below a nanometre the backlash is no gear's, and its
// products underflow (a denormal b makes the integrators' absolute tolerance tolerance x b zero).
constexpr double kMinBacklashUm = 1e-3;

// The accessor of member `Member` of section `Section` of a Case: one function per key, its
// type checked against the kind the table declares.
template <auto Section, auto Member>
auto& field(Case& c) {
  return (c.*Section).*Member;
}

template <auto Section, auto Member>
ChoiceField choice(std::vector<std::pair<std::string_view, int>> options) {
  return {[](const Case& c) { return static_cast<int>((c.*Section).*Member); },
          [](Case& c, int v) {
            using Enum = std::remove_reference_t<decltype((c.*Section).*Member)>;
            (c.*Section).*Member = static_cast<Enum>(v);
          },
          std::move(options)};
}

template <class Enum>
std::pair<std::string_view, int> option(std::string_view name, Enum value) {
  return {name, static_cast<int>(value)};
}

std::string& description(Case& c) { return c.description; }

Range closed(double lo, double hi) { return {lo, hi, true, true}; }
Range closed_open(double lo, double hi) { return {lo, hi, true, false}; }
Range open(double lo, double hi) { return {lo, hi, false, false}; }
Range open_closed(double lo, double hi) { return {lo, hi, false, true}; }
Range above(double lo) { return {lo, kInf, false, true}; }
Range at_least(double lo) { return {lo, kInf, true, true}; }
Range finite() { return {}; }

// The table. Order: as a case file is written and documented.
std::vector<CaseKey> make_keys() {
  using G = GearData;
  using M = MeshData;
  using L = LoadData;
  using S = SolverData;
  using D = ModelData;
  constexpr auto kGear = &Case::gear;
  constexpr auto kMesh = &Case::mesh;
  constexpr auto kLoad = &Case::load;
  constexpr auto kSolver = &Case::solver;
  constexpr auto kModel = &Case::model;
  const bool sweep = true, stiff = true;
  const int max_terms = HarmonicSeries::kMaxTerms;
  return {
      {"description", &description, "", {}, "", "", "free text shown in the summary"},

      {"model.form",
       choice<kModel, &D::form>({option("gear_pair", ModelForm::kGearPair),
                                 option("nondimensional", ModelForm::kNondimensional),
                                 option("coupled", ModelForm::kCoupled),
                                 option("train", ModelForm::kTrain)}),
       "",
       {},
       "",
       "",
       "the gear pair of the sections below; x'' + 2 zeta x' + k(tau) f(x) = F_m + F_a "
       "cos(Omega tau) with b = 1 (docs/sweeps.md); the gears as rigid bodies on [bearings] "
       "(docs/model.md); or a gear train of the elements in [train] (docs/case-files.md, "
       "\"Gear trains\")"},
      {"model.dof", &field<kModel, &D::dof>, "", closed(3, 12), "whole number", "(3, 6 or 12)",
       "with \"coupled\": 3 (rotations and translations along the line of action), 6 (and "
       "axial) or 12 (all six per gear)"},
      {"model.zeta", &field<kModel, &D::zeta>, "", closed_open(0, 1), "damping ratio", "",
       "damping ratio (non-dimensional form)", sweep},
      {"model.force_mean", &field<kModel, &D::force_mean>, "", finite(), "force", "", "F_m", sweep},
      {"model.force_alternating", &field<kModel, &D::force_alternating>, "", at_least(0),
       "amplitude", "", "F_a", sweep},
      {"model.omega", &field<kModel, &D::omega>, "", above(0), "frequency ratio", "", "Omega",
       sweep},
      {"model.stiffness_harmonics", &field<kModel, &D::stiffness_harmonics>, "", closed_open(0, 1),
       "ratio kappa_i", "(their sum below 1, so that k stays > 0)",
       "[kappa_i, phi_i_deg] pairs: k(tau) = 1 + sum kappa_i cos(i Omega tau + phi_i)", sweep},
      {"model.transmission_error", &field<kModel, &D::transmission_error>, "", at_least(0),
       "amplitude a_i (units of b)", "",
       "[a_i, phi_i_deg] pairs: the static transmission error e(tau) = sum a_i cos(i Omega tau + "
       "phi_i) in the mesh deflection (docs/model.md)",
       sweep},

      {"gear.normal_module_mm", &field<kGear, &G::normal_module_mm>, "mm", open_closed(0, 100),
       "module", "", "m_n", sweep, stiff},
      {"gear.normal_pressure_angle_deg", &field<kGear, &G::normal_pressure_angle_deg>, "degrees",
       open(0, 45), "angle", "", "alpha_n", sweep, stiff},
      {"gear.helix_angle_deg", &field<kGear, &G::helix_angle_deg>, "degrees", closed_open(0, 60),
       "angle", "(0 is a spur gear)", "beta", sweep, stiff},
      {"gear.center_distance_mm", &field<kGear, &G::center_distance_mm>, "mm", above(0), "distance",
       "", "a; must exceed the sum of the base radii (checked with the geometry)", sweep, stiff},
      {"gear.teeth", &field<kGear, &G::teeth>, "", closed(5, 10000), "whole number of teeth",
       "(external gears)", "[z1, z2], z1 driving", false, stiff},
      {"gear.face_width_mm", &field<kGear, &G::face_width_mm>, "mm", above(0), "width", "", "b_w",
       sweep, stiff},
      {"gear.outside_diameter_mm", &field<kGear, &G::outside_diameter_mm>, "mm", above(0),
       "diameter", "",
       "tip diameters d_a; each must exceed its base diameter and keep the tooth from coming to "
       "a point (checked with the geometry)",
       sweep, stiff},
      {"gear.profile_shift", &field<kGear, &G::profile_shift>, "", closed(-1.5, 1.5),
       "profile shift coefficient", "", "x1, x2", sweep, stiff},
      {"gear.density_kg_m3", &field<kGear, &G::density_kg_m3>, "kg/m^3", above(0), "density", "",
       "for the inertias", sweep},
      {"gear.bore_diameter_mm", &field<kGear, &G::bore_diameter_mm>, "mm", at_least(0), "diameter",
       "(0 is a solid blank)",
       "bore of each blank, below its root diameter: the inner radius of the energy method's "
       "fillet foundation (a solid blank counts as a hub of a third of the root radius), and of "
       "the inertia when none is given",
       sweep, stiff},
      {"gear.inertia_kg_m2", &field<kGear, &G::inertia_kg_m2>, "kg m^2", above(0),
       "moment of inertia", "", "[J1, J2]; overrides density and bore for the inertias only",
       sweep},
      {"gear.youngs_modulus_gpa", &field<kGear, &G::youngs_modulus_gpa>, "GPa", open(0, 2000),
       "Young's modulus", "", "E of each gear (mesh stiffness)", sweep, stiff},
      {"gear.poisson_ratio", &field<kGear, &G::poisson_ratio>, "", closed_open(0, 0.5),
       "Poisson's ratio", "", "nu of each gear", sweep, stiff},
      {"gear.basic_rack_dedendum", &field<kGear, &G::basic_rack_dedendum>, "", closed(1, 1.6),
       "basic rack dedendum h_fP/m_n", "(ISO 53: 1.25 to 1.4)",
       "h_fP/m_n (root circle; ISO 6336's C_B)", sweep, stiff},
      {"gear.rim_thickness_mm", &field<kGear, &G::rim_thickness_mm>, "mm", at_least(0), "thickness",
       "(0: solid blank)", "s_R (ISO 6336's C_R)", sweep, stiff},
      {"gear.web_thickness_mm", &field<kGear, &G::web_thickness_mm>, "mm", at_least(0), "thickness",
       "(0: solid blank)", "b_s (ISO 6336's C_R)", sweep, stiff},

      {"mesh.backlash_um", &field<kMesh, &M::backlash_um>, "um", at_least(kMinBacklashUm),
       "half backlash b", "(1 nm; the total normal backlash is 2b)",
       "b, half the total normal backlash 2b", sweep},
      {"mesh.stiffness_source",
       choice<kMesh, &M::stiffness_source>({option("energy", StiffnessSource::kEnergy),
                                            option("harmonics", StiffnessSource::kHarmonics),
                                            option("table", StiffnessSource::kTable),
                                            option("iso6336", StiffnessSource::kIso6336)}),
       "",
       {},
       "",
       "",
       "where k(t) comes from (docs/stiffness.md); harmonics given without a source select "
       "\"harmonics\"",
       false,
       stiff},
      {"mesh.mean_stiffness_n_per_m", &field<kMesh, &M::mean_stiffness_n_per_m>, "N/m", at_least(0),
       "stiffness",
       "(> 0 with \"harmonics\"; with \"energy\" or \"table\" 0 keeps the computed mean; not "
       "read with \"iso6336\")",
       "k_m (normal direction); the computed curve is scaled to it", sweep, stiff},
      {"mesh.stiffness_harmonics", &field<kMesh, &M::stiffness_harmonics>, "", closed_open(0, 1),
       "ratio k_ai/k_m", "(their sum below 1; only with \"harmonics\" or \"iso6336\")",
       "[k_ai/k_m, phi_i_deg] pairs of eq. 11, the i-th at i z1 f_1", sweep, stiff},
      {"mesh.stiffness_table",
       &field<kMesh, &M::stiffness_table>,
       "",
       {},
       "",
       "",
       "with \"table\": a CSV `position,stiffness_n_per_m` over one mesh cycle, relative to the "
       "case file",
       false,
       stiff},
      {"mesh.harmonics_kept", &field<kMesh, &M::harmonics_kept>, "", closed(0, max_terms),
       "whole number", "(below half of mesh.stiffness_positions)",
       "harmonics kept from the computed curve", false, stiff},
      {"mesh.stiffness_positions", &field<kMesh, &M::stiffness_positions>, "", closed(16, 65536),
       "whole number of mesh positions", "", "mesh positions per cycle (energy, table)", false,
       stiff},
      {"mesh.stiffness_slices", &field<kMesh, &M::stiffness_slices>, "", closed(1, 4096),
       "whole number of face-width slices", "", "face-width slices of the energy method", false,
       stiff},
      {"mesh.application_factor", &field<kMesh, &M::application_factor>, "", closed(1, 5),
       "application factor K_A", "", "K_A of ISO 6336-1's light-load factor", sweep, stiff},
      {"mesh.damping_ratio", &field<kMesh, &M::damping_ratio>, "", closed_open(0, 1),
       "damping ratio", "", "xi of the linearised contact oscillator", sweep},
      {"mesh.damping",
       choice<kMesh, &M::damping>(
           {option("contact", DampingForm::kContact), option("always", DampingForm::kAlways)}),
       "",
       {},
       "",
       "",
       "damping in contact only (the paper) or at all times (Kahraman and Singh)"},
      {"mesh.tension",
       choice<kMesh, &M::tension>(
           {option("allow", TensionRule::kAllow), option("clip", TensionRule::kClip)}),
       "",
       {},
       "",
       "",
       "F_G may pull in contact (the paper), or is clipped at 0 (with damping \"always\" the "
       "teeth alone are clipped, which never pull: docs/model.md)"},

      {"mesh.transmission_error_um", &field<kMesh, &M::transmission_error_um>, "um", at_least(0),
       "amplitude a_i", "",
       "[a_i, phi_i_deg] pairs: the static transmission error e(t) = sum a_i cos(i z1 omega_1 t "
       "+ phi_i) in the mesh deflection, F_G = k(t) (delta - e - b) + c (delta' - e') "
       "(docs/model.md)",
       sweep},
      {"mesh.transmission_error_table",
       &field<kMesh, &M::transmission_error_table>,
       "",
       {},
       "",
       "",
       "instead of the harmonics: a CSV `position,transmission_error_um` over one mesh cycle "
       "(as a loaded tooth contact program writes it), relative to the case file"},
      {"mesh.transmission_error_kept", &field<kMesh, &M::transmission_error_kept>, "",
       closed(1, kMaxErrorHarmonics), "whole number", "",
       "harmonics kept from the transmission error table"},

      {"load.torque_nm", &field<kLoad, &L::torque_nm>, "N m", finite(), "torque", "",
       "mean driving torque T1", sweep},
      {"load.fluctuation_ratio", &field<kLoad, &L::fluctuation_ratio>, "", at_least(0),
       "ratio F_a/F_m", "", "amplitude of T1's fluctuation over its mean, F_a/F_m", sweep},
      {"load.fluctuation_order", &field<kLoad, &L::fluctuation_order>, "", above(0), "order",
       "(torque frequency over shaft frequency)", "torque frequency over shaft frequency", sweep},
      {"load.fluctuation_phase_deg", &field<kLoad, &L::fluctuation_phase_deg>, "degrees", finite(),
       "phase", "", "phi of eq. 10", sweep},
      {"load.load_torque_nm", &field<kLoad, &L::load_torque_nm>, "N m", finite(), "torque", "",
       "mean load torque T2 (eq. 6); absent: matched load T2 = R_b2 T1(t) / R_b1 (eq. 7)", sweep},
      {"load.load_fluctuation_nm", &field<kLoad, &L::load_fluctuation_nm>, "N m", at_least(0),
       "amplitude", "(0: steady; else needs load.load_torque_nm)", "amplitude of T2's fluctuation",
       sweep},
      {"load.load_fluctuation_order", &field<kLoad, &L::load_fluctuation_order>, "", above(0),
       "order", "(load torque frequency over shaft frequency)",
       "load torque frequency over shaft frequency", sweep},
      {"load.load_fluctuation_phase_deg", &field<kLoad, &L::load_fluctuation_phase_deg>, "degrees",
       finite(), "phase", "", "phase of T2's fluctuation", sweep},

      {"speed.shaft_frequency_hz", &field<&Case::speed, &SpeedData::shaft_frequency_hz>, "Hz",
       above(0), "frequency", "", "f_1, rotation frequency of the driving gear", sweep},

      {"bearings.radial_stiffness_n_per_m",
       &field<&Case::bearings, &BearingData::radial_stiffness_n_per_m>, "N/m", above(0),
       "stiffness", "", "k_r of each gear's bearings, both radial directions", sweep},
      {"bearings.axial_stiffness_n_per_m",
       &field<&Case::bearings, &BearingData::axial_stiffness_n_per_m>, "N/m", above(0), "stiffness",
       "", "k_a of each gear's bearings", sweep},
      {"bearings.tilt_stiffness_n_m_per_rad",
       &field<&Case::bearings, &BearingData::tilt_stiffness_n_m_per_rad>, "N m/rad", above(0),
       "stiffness", "", "k_t of each gear's bearings, both tilts", sweep},
      {"bearings.damping_ratio", &field<&Case::bearings, &BearingData::damping_ratio>, "",
       closed_open(0, 1), "damping ratio", "",
       "of every bearing direction against the gear's mass or tilt inertia", sweep},
      {"bearings.radial_clearance_um", &field<&Case::bearings, &BearingData::radial_clearance_um>,
       "um", at_least(0), "clearance", "(0: none)",
       "along the line of action, a dead zone +-c with its own contact states (Kahraman and "
       "Singh 1991)",
       sweep},

      {"shafts.end_inertia_kg_m2", &field<&Case::shafts, &ShaftData::end_inertia_kg_m2>, "kg m^2",
       at_least(0), "moment of inertia", "(0: no shaft)",
       "[motor, load]: the inertia at the far end of a torsional shaft from each gear; T1 acts "
       "on the motor, T2 on the load (coupled model only)",
       sweep},
      {"shafts.stiffness_n_m_per_rad", &field<&Case::shafts, &ShaftData::stiffness_n_m_per_rad>,
       "N m/rad", above(0), "stiffness", "", "torsional stiffness of each shaft", sweep},
      {"shafts.damping_ratio", &field<&Case::shafts, &ShaftData::damping_ratio>, "",
       closed_open(0, 1), "damping ratio", "",
       "of each shaft against the reduced inertia of the two bodies it joins", sweep},

      {"solver.method",
       choice<kSolver, &S::method>({option("exact", Method::kExact),
                                    option("newmark", Method::kNewmark),
                                    option("dopri5", Method::kDopri5)}),
       "",
       {},
       "",
       "",
       "the exact engine (closed-form cells, located events; docs/numerics.md), the paper's "
       "Newmark-beta, or Dormand-Prince 5(4); left out, a train whose meshes' common period the "
       "exact engine's cells cannot hold (a hunting-tooth gearbox's) runs on dopri5, and the run "
       "says why"},
      {"solver.duration_s", &field<kSolver, &S::duration_s>, "s", above(0), "duration", "",
       "the window, from t = 0"},
      {"solver.time_step_s", &field<kSolver, &S::time_step_s>, "s", at_least(0), "step",
       "(0: automatic; else below solver.duration_s)",
       "Newmark step; 0: automatic (docs/numerics.md)"},
      {"solver.tolerance", &field<kSolver, &S::tolerance>, "", closed(1e-14, 1e-3), "tolerance", "",
       "exact: series truncated at 1e-4 x tolerance (floor 1e-16); dopri5: relative and "
       "absolute tolerance of every state component (the train's angles in rad and rates in "
       "rad/s, a pair's too); Newmark: its steps set the accuracy, the tolerance only the floor "
       "of the steady part's settling test"},
      {"solver.output_interval_s", &field<kSolver, &S::output_interval_s>, "s", at_least(0),
       "interval", "(0: automatic, duration / 5000; else at most solver.duration_s)",
       "sample spacing"},
      {"solver.final_fraction", &field<kSolver, &S::final_fraction>, "", open(0, 1), "fraction", "",
       "separation within this final part of the window is \"sustained\""},
      {"solver.initial",
       choice<kSolver, &S::initial>({option("center", InitialCondition::kCenter),
                                     option("static", InitialCondition::kStatic)}),
       "",
       {},
       "",
       "",
       "start at rest in the middle of the backlash (eq. 15) or at the static contact "
       "deflection"},
  };
}

std::string number_text(double x) { return fmt::format("{}", x); }

std::string_view article(std::string_view word) {
  return !word.empty() && std::string_view("aeiou").find(word.front()) != std::string_view::npos
             ? "an"
             : "a";
}

// A float as TOML, with the shortest digits that read back to the same double (154.98, not
// 154.97999999999999), in scientific form outside [1e-4, 1e6) (2.34e+08), and always with a
// point or an exponent so that it stays a float.
std::string toml_number(double x) {
  if (!std::isfinite(x)) return number_text(x);  // inf, -inf, nan: TOML's own
  const double a = std::abs(x);
  std::array<char, 32> buffer{};
  const auto format =
      a != 0 && (a < 1e-4 || a >= 1e6) ? std::chars_format::scientific : std::chars_format::fixed;
  const auto [end, ec] = std::to_chars(buffer.data(), buffer.data() + buffer.size(), x, format);
  std::string t(buffer.data(), ec == std::errc() ? end : buffer.data());
  if (t.find_first_of(".e") == std::string::npos) t += ".0";
  return t;
}

}  // namespace

bool Range::contains(double x) const {
  if (!std::isfinite(x)) return false;
  const bool lo_ok = lo_closed ? x >= lo : x > lo;
  const bool hi_ok = hi_closed ? x <= hi : x < hi;
  return lo_ok && hi_ok;
}

std::string Range::text(bool integer) const {
  const bool has_lo = std::isfinite(lo), has_hi = std::isfinite(hi);
  if (has_lo && has_hi) {
    if (integer) return fmt::format("from {} to {}", lo, hi);
    return fmt::format("in {}{}, {}{}", lo_closed ? '[' : '(', number_text(lo), number_text(hi),
                       hi_closed ? ']' : ')');
  }
  if (has_lo) return fmt::format("{} {}", lo_closed ? "of at least" : ">", number_text(lo));
  if (has_hi) return fmt::format("{} {}", hi_closed ? "<=" : "<", number_text(hi));
  return "";
}

std::string_view CaseKey::section() const {
  const auto dot = name.find('.');
  return dot == std::string_view::npos ? std::string_view() : name.substr(0, dot);
}

std::string_view CaseKey::leaf() const {
  const auto dot = name.find('.');
  return dot == std::string_view::npos ? name : name.substr(dot + 1);
}

bool CaseKey::optional() const {
  return std::holds_alternative<OptionalNumberField>(field) ||
         std::holds_alternative<OptionalPairField>(field);
}

bool CaseKey::integer() const {
  return std::holds_alternative<IntegerField>(field) ||
         std::holds_alternative<IntegerPairField>(field);
}

std::string CaseKey::allowed() const {
  if (const auto* c = std::get_if<ChoiceField>(&field)) {
    std::string names;
    for (const auto& [n, v] : c->options)
      names += fmt::format("{}\"{}\"", names.empty() ? "" : " | ", n);
    return "one of " + names;
  }
  if (std::holds_alternative<TextField>(field)) return "a string";
  const bool bounded_above = std::isfinite(range.hi);
  std::string out;
  if (bounded_above || integer()) {
    out = fmt::format("{} {}", article(what), what);
  } else {
    out = fmt::format("a finite {}", what);
  }
  const std::string bound = range.text(integer());
  if (!bound.empty()) out += " " + bound;
  if (!unit.empty()) out += bound.empty() ? fmt::format(" ({})", unit) : fmt::format(" {}", unit);
  if (!note.empty()) out += fmt::format(" {}", note);
  return out;
}

namespace {

// A key's value in a case as TOML text, by the kind of the key.
class ValueText {
 public:
  explicit ValueText(const Case& c) : m_(const_cast<Case&>(c)) {}  // the accessors only read

  std::string operator()(NumberField f) const { return toml_number(f(m_)); }
  std::string operator()(OptionalNumberField f) const {
    return f(m_) ? toml_number(*f(m_)) : "absent";
  }
  std::string operator()(IntegerField f) const { return fmt::format("{}", f(m_)); }
  std::string operator()(PairField f) const { return pair(f(m_)); }
  std::string operator()(OptionalPairField f) const { return f(m_) ? pair(*f(m_)) : "absent"; }
  std::string operator()(IntegerPairField f) const {
    return fmt::format("[{}, {}]", f(m_)[0], f(m_)[1]);
  }
  std::string operator()(HarmonicsField f) const { return pairs(f(m_)); }
  std::string operator()(ErrorHarmonicsField f) const { return pairs(f(m_)); }
  // TOML's basic strings share JSON's escapes.
  std::string operator()(TextField f) const { return nlohmann::json(f(m_)).dump(); }
  std::string operator()(const ChoiceField& f) const {
    const int v = f.get(m_);
    for (const auto& [n, value] : f.options)
      if (value == v) return fmt::format("\"{}\"", n);
    return "?";
  }

 private:
  static std::string pair(const std::array<double, 2>& v) {
    return fmt::format("[{}, {}]", toml_number(v[0]), toml_number(v[1]));
  }
  template <class Term>
  static std::string pairs(const std::vector<Term>& terms) {
    std::string out;
    for (const auto& [value, phase_deg] : terms)
      out += fmt::format("{}[{}, {}]", out.empty() ? "" : ", ", toml_number(value),
                         toml_number(phase_deg));
    return "[" + out + "]";
  }

  Case& m_;
};

}  // namespace

std::string CaseKey::value_text(const Case& c) const { return std::visit(ValueText(c), field); }

const std::vector<CaseKey>& case_keys() {
  static const std::vector<CaseKey> keys = make_keys();
  return keys;
}

const CaseKey* find_case_key(std::string_view dotted) {
  const std::string_view base = dotted.substr(0, dotted.find('['));
  for (const CaseKey& k : case_keys())
    if (k.name == base) return &k;
  return nullptr;
}

bool changes_stiffness(std::string_view dotted) {
  const CaseKey* k = find_case_key(dotted);
  return k == nullptr || k->changes_stiffness;
}

std::string check_sweepable(std::string_view dotted) {
  const CaseKey* k = find_case_key(dotted);
  if (k && k->sweepable) return {};
  std::string why =
      !k ? "unknown key"
         : "not a real number the model reads (solver settings, counts, choices and text are "
           "not varied by a study)";
  if (dotted.starts_with("train.")) {
    why = train_key_not_sweepable(dotted);
    if (why.empty()) return {};
  }
  return fmt::format(
      "{}: {}; `geardyn keys` lists the keys a study may vary (an element of an array as "
      "key[i])",
      dotted, why);
}

std::string case_keys_markdown() {
  std::string out;
  std::string_view section = "-";
  const Case defaults;
  for (const CaseKey& k : case_keys()) {
    if (k.section().empty()) continue;  // the description, documented in the text
    if (k.section() != section) {
      section = k.section();
      out += fmt::format(
          "{}## [{}]\n\n| key | unit | default | allowed | sweep | meaning |\n"
          "|---|---|---|---|---|---|\n",
          out.empty() ? "" : "\n", section);
    }
    std::string allowed;
    if (const auto* c = std::get_if<ChoiceField>(&k.field)) {
      for (const auto& [n, v] : c->options)
        allowed += fmt::format("{}\"{}\"", allowed.empty() ? "" : ", ", n);
    } else if (std::holds_alternative<TextField>(k.field)) {
      allowed = "a string";
    } else {
      allowed = k.range.text(k.integer());
      for (const char* word : {"in ", "of at least "})
        if (allowed.rfind(word, 0) == 0)
          allowed.replace(0, std::string_view(word).size(), word[0] == 'i' ? "" : ">= ");
      if (allowed.empty()) allowed = "finite";
      if (std::holds_alternative<HarmonicsField>(k.field))
        allowed = fmt::format("pairs [ratio {}, phase_deg], at most {}", allowed,
                              HarmonicSeries::kMaxTerms);
      if (std::holds_alternative<ErrorHarmonicsField>(k.field))
        allowed =
            fmt::format("pairs [amplitude {}, phase_deg], at most {}", allowed, kMaxErrorHarmonics);
      if (!k.note.empty()) allowed += fmt::format(" {}", k.note);
    }
    std::string sweep = k.sweepable ? "yes" : "";
    if (k.changes_stiffness) sweep += sweep.empty() ? "(k)" : " (k)";
    out += fmt::format("| {} | {} | {} | {} | {} | {} |\n", k.leaf(), k.unit,
                       k.value_text(defaults), allowed, sweep, k.doc);
  }
  return out;
}

std::string unused_reason(const CaseKey& k, const Case& c) {
  const std::string_view section = k.section();
  const ModelForm form = c.model.form;
  const std::string form_text = fmt::format("model.form = \"{}\"", to_string(form));
  // By form: which sections it reads.
  if (form == ModelForm::kTrain) {
    if (!section.empty() && section != "solver" && k.name != "model.form")
      return form_text + " reads [train] and [solver] (its elements carry their own data)";
  } else if (k.name == "model.dof" || section == "bearings" || section == "shafts") {
    if (form != ModelForm::kCoupled)
      return form_text + " has no bearings or shafts (only \"coupled\" reads them)";
  } else if (section == "model" && k.name != "model.form") {
    if (form != ModelForm::kNondimensional)
      return form_text +
             " reads [gear], [mesh], [load] and [speed] (only \"nondimensional\" "
             "reads " +
             std::string(k.name) + ")";
  } else if (section == "gear" || section == "mesh" || section == "load" || section == "speed") {
    if (form == ModelForm::kNondimensional)
      return form_text + " reads [model] only (b = 1, times in tau)";
  }
  // By key: settings of a method or a source that is not chosen.
  const SolverData& s = c.solver;
  if (k.name == "solver.time_step_s" && s.method != Method::kNewmark && s.time_step_s != 0)
    return fmt::format(
        "solver.method = \"{}\" chooses its own steps (only \"newmark\" takes a "
        "time step)",
        to_string(s.method));
  if (k.name == "mesh.stiffness_table" && c.mesh.stiffness_source != StiffnessSource::kTable &&
      !c.mesh.stiffness_table.empty())
    return "mesh.stiffness_source is not \"table\"";
  if ((k.name == "mesh.mean_stiffness_n_per_m" || k.name == "mesh.harmonics_kept" ||
       k.name == "mesh.stiffness_slices") &&
      c.mesh.stiffness_source == StiffnessSource::kIso6336)
    return "mesh.stiffness_source = \"iso6336\" takes k_m from ISO 6336-1 (c_gamma_alpha b) and "
           "the harmonics as given";
  if (k.name == "mesh.transmission_error_kept" && c.mesh.transmission_error_table.empty())
    return "there is no mesh.transmission_error_table to keep harmonics of";
  if ((k.name == "load.load_fluctuation_order" || k.name == "load.load_fluctuation_phase_deg") &&
      c.load.load_fluctuation_nm == 0)
    return "load.load_fluctuation_nm = 0: the load torque does not fluctuate";
  if ((k.name == "load.fluctuation_order" || k.name == "load.fluctuation_phase_deg") &&
      c.load.fluctuation_ratio == 0)
    return "load.fluctuation_ratio = 0: the driving torque does not fluctuate";
  return {};
}

std::vector<std::string> unused_settings(const Case& c, Integration integration) {
  std::vector<std::string> out;
  const Case defaults;
  for (const CaseKey& k : case_keys()) {
    const auto given = c.origins.find(std::string(k.name));
    // A key given at its default changes nothing, used or not (a case file that writes every
    // key out, as cases/park2010.toml does, is not warned about).
    if (given == c.origins.end() || k.value_text(c) == k.value_text(defaults)) continue;
    std::string why = unused_reason(k, c);
    if (why.empty() && integration == Integration::kExactEngine &&
        (k.name == "solver.method" || k.name == "solver.time_step_s"))
      why = kExactEngineOnly;
    if (!why.empty())
      out.push_back(
          fmt::format("{} = {} ({}): not used: {}", k.name, k.value_text(c), given->second, why));
  }
  if (c.train)
    for (std::string& x : train_unused_settings(*c.train)) out.push_back(std::move(x));
  return out;
}

std::string unread_study_key(const Case& c, const std::vector<std::vector<Override>>& corners) {
  std::string line;
  for (const std::vector<Override>& corner : corners) {
    if (corner.empty()) continue;
    Case at = c;
    for (const Override& o : corner) set_case_value(at, o);
    const Override& o = corner.front();
    std::string found;
    if (const CaseKey* k = find_case_key(o.key); k && !o.key.starts_with("train.")) {
      // Its reason whatever its value (unused_settings passes over a key at its default).
      if (const std::string why = unused_reason(*k, at); !why.empty())
        found =
            fmt::format("{} = {} ({}): not used: {}", k->name, k->value_text(at), o.label(), why);
    } else {
      // A train's element key: its line of the train's unused settings, the index of a
      // harmonic's entry dropped (key[i][j]).
      const std::size_t dot = o.key.rfind('.');
      const std::string stem = o.key.substr(0, o.key.find('[', dot == std::string::npos ? 0 : dot));
      for (const std::string& x : unused_settings(at))
        if (x.starts_with(stem + " =") || x.starts_with(stem + " (")) found = x;
    }
    if (found.empty()) return {};  // read at this corner
    if (line.empty()) line = found;
  }
  return line;
}

std::string form_key(const std::string& key, ModelForm form) {
  if (form == ModelForm::kGearPair || key == "wall_time_s") return key;
  if (key == "t_s") return "tau";
  const auto ends = [&](std::string_view suffix) {
    return key.size() > suffix.size() &&
           key.compare(key.size() - suffix.size(), suffix.size(), suffix) == 0;
  };
  const auto stem = [&](std::string_view suffix) {
    return key.substr(0, key.size() - suffix.size());
  };
  // Longest suffixes first: "_n_s_per_m" and "_m_s" end in "_s" too.
  for (std::string_view dropped : {"_n_s_per_m", "_n_per_m", "_m_s", "_kg", "_um", "_n"})
    if (ends(dropped)) return stem(dropped);
  if (ends("_s")) return stem("_s") + "_tau";
  if (ends("_hz")) return stem("_hz") + "_per_tau";
  return key;
}

}  // namespace geardyn
