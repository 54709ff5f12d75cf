// `geardyn geometry`: the derived geometry of a gear pair (a train's: one of its meshes').
#include "geardyn/geometry.hpp"

#include <fmt/format.h>

#include <memory>

#include "../cli.hpp"
#include "../commands.hpp"
#include "geardyn/case_model.hpp"
#include "geardyn/output.hpp"
#include "geardyn/train_case.hpp"
#include "geardyn/train_presets.hpp"

namespace geardyn::cli {
namespace {

// The gear pair the geometry command reads (gear_pair_to_read).
geardyn::GearPairToRead pair_to_read(const CaseArgs& input, const std::string& mesh,
                                     std::string_view command) {
  const geardyn::Case c = read_case(input);
  check_command_takes(c, command);
  return geardyn::gear_pair_to_read(c, mesh);
}

int cmd_geometry(const CaseArgs& input, const std::string& mesh, bool json) {
  const geardyn::GearPairToRead read = pair_to_read(input, mesh, "geometry");
  const geardyn::Case& c = read.pair;
  const geardyn::Geometry g = geardyn::case_geometry(c);
  constexpr double kDeg = 180.0 / 3.14159265358979323846;
  constexpr double kMm = 1e3;
  if (json) {
    fmt::print("{}\n", geardyn::geometry_json(g));
    return 0;
  }
  print_warnings(read.warnings);
  fmt::print("geometry of {}\n", c.name);
  fmt::print("  transverse module          {:.6f} mm\n", g.transverse_module_m * kMm);
  fmt::print("  transverse pressure angle  {:.6f} deg\n", g.transverse_pressure_angle_rad * kDeg);
  fmt::print("  base helix angle           {:.6f} deg\n", g.base_helix_angle_rad * kDeg);
  fmt::print("  reference diameters        {:.4f}, {:.4f} mm\n", g.reference_diameter_m[0] * kMm,
             g.reference_diameter_m[1] * kMm);
  fmt::print("  base diameters             {:.4f}, {:.4f} mm\n", 2 * g.base_radius_m[0] * kMm,
             2 * g.base_radius_m[1] * kMm);
  fmt::print("  outside diameters          {:.4f}, {:.4f} mm (standard rack: {:.4f}, {:.4f})\n",
             2 * g.tip_radius_m[0] * kMm, 2 * g.tip_radius_m[1] * kMm,
             g.expected_outside_diameter_m[0] * kMm, g.expected_outside_diameter_m[1] * kMm);
  fmt::print(
      "  centre distance            {:.4f} mm (profile shifts imply {:.4f}, reference "
      "{:.4f})\n",
      g.center_distance_m * kMm, g.shift_center_distance_m * kMm,
      g.reference_center_distance_m * kMm);
  fmt::print("  working pressure angle     {:.6f} deg (from the shifts {:.6f})\n",
             g.working_pressure_angle_rad * kDeg, g.shift_working_pressure_angle_rad * kDeg);
  fmt::print("  contact ratios             eps_alpha {:.4f}, eps_beta {:.4f}, total {:.4f}\n",
             g.transverse_contact_ratio, g.overlap_ratio, g.total_contact_ratio());
  fmt::print("  inertias                   {:.6g}, {:.6g} kg m^2\n", g.inertia_kg_m2[0],
             g.inertia_kg_m2[1]);
  fmt::print("  equivalent mass m_eq       {:.6g} kg\n", g.equivalent_mass_kg);
  return 0;
}

}  // namespace

Command add_geometry(CLI::App& geardyn) {
  struct Options {
    CaseArgs input;
    bool json = false;
    std::string mesh;
  };
  auto o = std::make_shared<Options>();
  CLI::App* geometry = geardyn.add_subcommand("geometry", "print the derived gear geometry");
  add_case_args(geometry, o->input);
  geometry->add_flag("--json", o->json, "print JSON");
  geometry->add_option("--mesh", o->mesh,
                       "a gear train's mesh whose gear pair is read (default: the first)");
  return {geometry, [o] { return cmd_geometry(o->input, o->mesh, o->json); }};
}

}  // namespace geardyn::cli
