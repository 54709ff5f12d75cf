// `geardyn orbit`: a periodic motion found by shooting, its state, Floquet multipliers,
// stability and contact sequence (a train's, or a pair's form's).
#include "geardyn/orbit.hpp"

#include <fmt/format.h>

#include <algorithm>
#include <cmath>
#include <memory>
#include <optional>

#include "../cli.hpp"
#include "../commands.hpp"
#include "geardyn/train_orbit.hpp"
#include "geardyn/train_run.hpp"

namespace geardyn::cli {
namespace {

// The region's name in an orbit's report.
const char* contact_name(int region) {
  switch (geardyn::contact_state(region)) {
    case 1:
      return "drive contact";
    case -1:
      return "back contact";
    default:
      return "separated";
  }
}

// An orbit's Floquet multipliers (the four largest) and whether it is stable, as `geardyn orbit`
// prints them for a train (and the coupled pair as its train).
void print_multipliers(const geardyn::PeriodicSolution& r) {
  fmt::print("  multipliers       {}, the largest:\n", r.multipliers.size());
  for (std::size_t k = 0; k < std::min<std::size_t>(r.multipliers.size(), 4); ++k)
    fmt::print("                    {:.9g}{:+.9g}i (|mu| {:.9g})\n", r.multipliers[k].real(),
               r.multipliers[k].imag(), std::abs(r.multipliers[k]));
  fmt::print("  stable            {}\n", r.stable ? "yes" : "no");
}

// A gear train's orbit (train_orbit.hpp), or the coupled pair's as its train form: its period,
// Newton, multipliers, each mesh's impacts per period and each clearance's.
int cmd_train_orbit(const geardyn::Case& c, const geardyn::OrbitOptions& o,
                    const std::vector<double>& state, bool json) {
  std::optional<geardyn::ode::Vector> start;
  if (!state.empty())
    start = Eigen::Map<const geardyn::ode::Vector>(state.data(),
                                                   static_cast<Eigen::Index>(state.size()));
  const geardyn::TrainOrbit r = geardyn::find_train_orbit(c, o, start);
  if (json) {
    fmt::print("{}\n", geardyn::train_orbit_json(r));
    return r.converged ? 0 : kExitNumerical;
  }
  fmt::print("geardyn orbit: {} ({}){}\n", c.name, as_train(c),
             c.description.empty() ? "" : " - " + c.description);
  if (!r.converged) {
    fmt::print(stderr, "geardyn: the orbit was not found: {}\n", r.message);
    return kExitNumerical;
  }
  fmt::print(
      "  period            {:.9g} s = {} x the system period {:.9g} s ({} shooting segment{})\n",
      r.period_s, r.periods, r.system_period_s, r.segments, r.segments == 1 ? "" : "s");
  fmt::print("  Newton            {}\n", r.message);
  fmt::print(
      "  unknowns          {} (the free coordinates and rates{}; --json prints the state)\n",
      r.coordinates.size(),
      r.modulo_rotation ? ", modulo the train's free rotation at its nominal mean speed" : "");
  print_multipliers(r);
  for (std::size_t m = 0; m < r.meshes.size(); ++m) {
    const geardyn::TrainMeshReading& x = r.readings[m];
    fmt::print(
        "  mesh {:<12} {} impacts/period ({} back side), (d - e)/b {:.9g} to {:.9g}, "
        "F {:.9g} to {:.9g} N\n",
        r.meshes[m], r.impacts_per_period[m], r.backside_impacts_per_period[m],
        x.min_deflection_m / x.backlash_m, x.max_deflection_m / x.backlash_m, x.min_force_n,
        x.max_force_n);
  }
  for (std::size_t k = 0; k < r.clearances.size(); ++k)
    fmt::print("  clearance {:<12} {} impacts/period, separations {}\n", r.clearances[k],
               r.clearance_readings[k].impacts, r.clearance_readings[k].separations);
  if (!r.sequence.empty()) {
    fmt::print("  contact sequence  (time from the section)\n");
    for (const geardyn::TrainContactEvent& e : r.sequence) {
      const auto part = static_cast<std::size_t>(e.part);
      fmt::print("    {:.9g} s  {} {}: {}, velocity {:.6g} m/s\n", e.t_s,
                 part < r.meshes.size() ? "mesh" : "clearance",
                 part < r.meshes.size() ? r.meshes[part] : r.clearances[part - r.meshes.size()],
                 geardyn::to_string(e.kind), e.velocity_m_s);
    }
  }
  return 0;
}

int cmd_orbit(const CaseArgs& input, const geardyn::OrbitOptions& o,
              const std::vector<double>& state, bool json) {
  const geardyn::Case c = load_model_case(input, "orbit");
  if (geardyn::runs_as_train(c)) return cmd_train_orbit(c, o, state, json);
  std::optional<geardyn::ode::State> start;
  if (!state.empty()) {
    if (state.size() != 2)
      throw geardyn::InputError(fmt::format(
          "--state: {} value{} given; it takes two, delta (m) and delta' (m/s) at t = 0",
          state.size(), state.size() == 1 ? "" : "s"));
    start = geardyn::ode::State{0.0, state[0], state[1], 0.0, 0};
  }
  const geardyn::Orbit r = geardyn::find_orbit(c, o, start);
  const bool nd = c.model.form == geardyn::ModelForm::kNondimensional;
  const double b = nd ? 1.0 : c.mesh.backlash_um * 1e-6;
  if (json) {
    fmt::print("{}\n", geardyn::orbit_json(r));
    return r.converged ? 0 : kExitNumerical;
  }
  const char* t_unit = nd ? "" : " s";
  fmt::print("geardyn orbit: {}{}\n", c.name, c.description.empty() ? "" : " - " + c.description);
  if (!r.converged) {
    fmt::print(stderr, "geardyn: the orbit was not found: {}\n", r.message);
    return kExitNumerical;
  }
  fmt::print(
      "  period            {:.9g}{} = {} x the system period {:.9g}{} ({} shooting segment{})\n",
      r.period_s, t_unit, r.periods, r.system_period_s, t_unit, r.segments,
      r.segments == 1 ? "" : "s");
  fmt::print("  Newton            {}\n", r.message);
  fmt::print("  section state     delta_bar {:.12g}, velocity {:.12g}{} ({})\n", r.state.q / b,
             r.state.v, nd ? "" : " m/s", contact_name(r.state.region));
  fmt::print("  multipliers      ");
  for (const auto& m : r.multipliers)
    fmt::print(" {:.9g}{:+.9g}i (|mu| {:.9g})", m.real(), m.imag(), std::abs(m));
  fmt::print("\n  stable            {}\n", r.stable ? "yes" : "no");
  fmt::print("  impacts/period    {} ({} back side), separations {}\n", r.reading.impacts,
             r.reading.backside_impacts, r.reading.separations);
  fmt::print("  delta_bar         min {:.9g}  max {:.9g}\n", r.reading.min_delta_bar,
             r.reading.max_delta_bar);
  fmt::print("  F_bar             min {:.9g}  max {:.9g}\n", r.reading.min_force_bar,
             r.reading.max_force_bar);
  if (!r.sequence.empty()) {
    fmt::print("  contact sequence  (time from the section)\n");
    for (const auto& e : r.sequence)
      fmt::print("    {:.9g}{}  {}, velocity {:.6g}{}\n", e.t_s, t_unit, geardyn::to_string(e.kind),
                 e.velocity_m_s, nd ? "" : " m/s");
  }
  return 0;
}

}  // namespace

Command add_orbit(CLI::App& geardyn) {
  struct Options {
    CaseArgs input;
    OrbitOptions orbit;
    std::vector<double> state;
    bool json = false;
  };
  auto o = std::make_shared<Options>();
  OrbitOptions& oo = o->orbit;
  CLI::App* orbit = geardyn.add_subcommand(
      "orbit", "find a periodic motion by shooting: its state, multipliers and stability");
  add_case_args(orbit, o->input);
  orbit->add_option("--periods", oo.periods, "period in system periods (default 1)");
  orbit->add_option("--segments", oo.segments, "shooting segments (default: one per period)");
  orbit->add_option("--settle-periods", oo.settle_periods,
                    "system periods simulated for the first guess (default 100)");
  orbit->add_option("--starts", oo.starts,
                    "settled states Newton starts from at most, one orbit period apart "
                    "(default 16)");
  orbit
      ->add_option("--state", o->state,
                   "first guess on the section t = 0: delta (m) and delta' (m/s); a gear "
                   "train or coupled case: its unknowns (--json's \"unknowns\", SI)")
      // As many as the case takes (a train's free coordinates and rates: any number); the
      // count is checked against the case, naming what it takes.
      ->expected(1, CLI::detail::expected_max_vector_size);
  orbit->add_option("--tolerance", oo.tolerance, "Newton's tolerance on the scaled residual");
  orbit->add_option("--max-iterations", oo.max_iterations, "Newton iterations at most (40)");
  orbit->add_flag("--json", o->json, "print JSON");
  return {orbit, [o, orbit] {
            // The settling gives the first guesses: with --state, or without settling, its
            // options are not used, and the user is told so.
            for (const char* opt : {"--settle-periods", "--starts"}) {
              const bool unused = !o->state.empty() ||
                                  (o->orbit.settle_periods == 0 && std::string(opt) == "--starts");
              if (unused && orbit->count(opt) > 0)
                fmt::print(stderr, "geardyn: warning: {} is not used: {}\n", opt,
                           o->state.empty() ? "--settle-periods 0 settles nothing"
                                            : "--state is the first guess");
            }
            return cmd_orbit(o->input, o->orbit, o->state, o->json);
          }};
}

}  // namespace geardyn::cli
