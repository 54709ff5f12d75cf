// `geardyn stiffness`: a gear pair's mesh stiffness from its gear data, by ISO 6336-1 and by the
// energy method over one mesh cycle, with its harmonics, files and figure.
#include "geardyn/stiffness.hpp"

#include <fmt/format.h>

#include <memory>

#include "../cli.hpp"
#include "../commands.hpp"
#include "geardyn/figures.hpp"
#include "geardyn/mesh_stiffness_report.hpp"
#include "geardyn/output.hpp"

namespace geardyn::cli {
namespace {

// The files stiffness always writes with --out, its figure aside.
const std::vector<std::string> kStiffnessFiles = {"stiffness.csv", "harmonics.json"};

// Harmonics shown in the stiffness figure's DFT panels.
constexpr int kFigureHarmonics = 10;

int cmd_stiffness(const CaseArgs& input, const std::string& mesh, const std::string& out_dir,
                  bool json) {
  const geardyn::Case of = read_case(input);
  check_command_takes(of, "stiffness");
  const geardyn::MeshStiffnessReport read = geardyn::mesh_stiffness_report(of, mesh);
  const geardyn::Case& c = read.pair;
  check_output_folder(out_dir, "stiffness", kStiffnessFiles);
  const geardyn::Geometry& g = read.geometry;
  const geardyn::Iso6336Stiffness& iso = read.iso;
  const geardyn::StiffnessCycle& cycle = read.cycle;
  const geardyn::StiffnessFourier& kept = read.kept;
  const std::string report = geardyn::stiffness_json(c, g, iso, cycle, kept);
  if (!out_dir.empty()) {
    write_output(out_dir, "stiffness", [&](const std::filesystem::path& d) {
      geardyn::write_files_atomically(
          d, {{"stiffness.csv", geardyn::stiffness_csv(g, cycle, kept, read.used)},
              {"harmonics.json", report + "\n"}});
      geardyn::write_stiffness_figure(
          d,
          c.name + (read.internal ? ": mesh stiffness (energy method, internal)"
                                  : ": mesh stiffness (energy method)"),
          cycle, geardyn::fourier_harmonics(cycle, kFigureHarmonics),
          c.mesh.stiffness_source == geardyn::StiffnessSource::kHarmonics ||
                  c.mesh.stiffness_source == geardyn::StiffnessSource::kIso6336
              ? 0
              : c.mesh.harmonics_kept,
          read.used);
    });
  }
  if (json) {
    fmt::print("{}\n", report);
    return 0;
  }
  print_warnings(read.warnings);
  fmt::print("mesh stiffness of {} (normal direction{})\n", c.name,
             read.internal ? "; an internal pair: its pinion, then its ring" : "");
  fmt::print(
      "  ISO 6336-1 Method B   c'_th {:.4f}, c' {:.4f}, c_gamma_alpha {:.4f}, "
      "c_gamma_beta {:.4f} N/(mm um)\n",
      iso.c_prime_th, iso.c_prime, iso.c_gamma_alpha, iso.c_gamma_beta);
  fmt::print("                        c_gamma_alpha b = {:.4g} N/m (load factor {:.3f})\n",
             iso.mesh_stiffness_n_per_m, iso.load_factor);
  fmt::print(
      "  energy method         mean {:.4g} N/m, min {:.4g}, max {:.4g} "
      "({} positions x {} slices)\n",
      cycle.mean_n_per_m(), cycle.min_n_per_m(), cycle.max_n_per_m(), cycle.position.size(),
      c.mesh.stiffness_slices);
  fmt::print(
      "                        pairs in contact {:.4f} on average "
      "(eps_alpha + eps_beta = {:.4f})\n",
      cycle.mean_pairs_in_contact(), g.total_contact_ratio());
  for (std::size_t i = 0; i < kept.harmonics.size(); ++i)
    fmt::print("                        k_a{}/k_m = {:.5f}, phi_{} = {:.2f} deg\n", i + 1,
               kept.harmonics[i].ratio, i + 1, kept.harmonics[i].phase_deg);
  fmt::print("                        series of {} harmonics within {:.2f} % of the curve\n",
             kept.harmonics.size(), 100 * geardyn::truncation_error(cycle, kept));
  fmt::print("  the case's k_m        {:.4g} N/m{}\n", c.mesh.mean_stiffness_n_per_m,
             c.mesh.mean_stiffness_n_per_m == 2.34e8 ? " (Table 1 of Park 2010)" : "");
  if (!out_dir.empty())
    fmt::print("  written to            {}/ (stiffness.csv, harmonics.json, stiffness.png, .svg)\n",
               out_dir);
  return 0;
}

}  // namespace

Command add_stiffness(CLI::App& geardyn) {
  struct Options {
    CaseArgs input;
    std::string out_dir;
    bool json = false;
    std::string mesh;
  };
  auto o = std::make_shared<Options>();
  CLI::App* stiffness = geardyn.add_subcommand(
      "stiffness", "mesh stiffness from the gear data: ISO 6336-1 and the energy method");
  add_case_args(stiffness, o->input);
  stiffness->add_option("--out", o->out_dir, "directory for stiffness.csv, harmonics.json, figure");
  stiffness->add_flag("--json", o->json, "print JSON");
  stiffness->add_option("--mesh", o->mesh,
                        "a gear train's mesh whose gear pair is read (default: the first)");
  return {stiffness, [o] {
            if (!o->out_dir.empty()) check_output_directory(o->out_dir);
            return cmd_stiffness(o->input, o->mesh, o->out_dir, o->json);
          }};
}

}  // namespace geardyn::cli
