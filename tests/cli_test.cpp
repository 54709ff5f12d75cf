// The command-line tool end to end: outputs, exit codes and messages.
#include <fmt/format.h>
#include <gtest/gtest.h>
#include <sys/wait.h>
#include <unistd.h>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <map>
#include <nlohmann/json.hpp>
#include <numbers>
#include <set>
#include <sstream>
#include <tuple>

#include "geardyn/train_presets.hpp"

namespace {

namespace fs = std::filesystem;

struct Outcome {
  int code;
  std::string out, err;
};

std::string slurp(const fs::path& p) {
  std::ifstream in(p);
  std::stringstream s;
  s << in.rdbuf();
  return s.str();
}

// A CSV file as its header line and its rows of fields (split at commas; no quoting).
struct CsvTable {
  std::string header;
  std::vector<std::string> names;
  std::vector<std::vector<std::string>> rows;
  // The index of a named column, names.size() when there is none.
  std::size_t column(const std::string& name) const {
    return static_cast<std::size_t>(std::find(names.begin(), names.end(), name) - names.begin());
  }
};
CsvTable read_csv(const fs::path& p) {
  const auto split = [](const std::string& line) {
    std::vector<std::string> cells;
    std::istringstream fields(line);
    for (std::string f; std::getline(fields, f, ',');) cells.push_back(f);
    return cells;
  };
  CsvTable t;
  std::istringstream csv(slurp(p));
  std::getline(csv, t.header);
  t.names = split(t.header);
  for (std::string line; std::getline(csv, line);) t.rows.push_back(split(line));
  return t;
}

// A shell command line, its exit code and both streams.
Outcome shell(const std::string& command) {
  const fs::path tmp = fs::temp_directory_path() / ("geardyn_cli_test_" + std::to_string(getpid()));
  fs::create_directories(tmp);
  // Grouped, so that the streams of every command in it (a background one too) are caught.
  const std::string cmd = "{ " + command + "; } >" + (tmp / "out").string() + " 2>" +
                          (tmp / "err").string() + " </dev/null";
  const int status = std::system(cmd.c_str());
  return {WEXITSTATUS(status), slurp(tmp / "out"), slurp(tmp / "err")};
}

Outcome cli(const std::string& args) { return shell(std::string(GEARDYN_CLI) + " " + args); }

// A refusal: exit 2, and `message` in what the program wrote to stderr.
void expect_refused(const Outcome& o, const std::string& message) {
  EXPECT_EQ(o.code, 2) << o.err;
  EXPECT_NE(o.err.find(message), std::string::npos) << "expected: " << message << "\n" << o.err;
}

// A shipped case file's path (cases/ of the sources).
std::string case_path(const std::string& file) {
  return std::string(GEARDYN_SOURCE_DIR) + "/cases/" + file;
}

fs::path fresh(const std::string& name) {
  const fs::path d =
      fs::temp_directory_path() / ("geardyn_cli_" + name + "_" + std::to_string(getpid()));
  fs::remove_all(d);
  return d;
}

const std::string kCase = case_path("park2010.toml");

// The shipped wind-turbine gearbox as its user runs it: the generator at 1800 rpm is the
// reference, the rotor drives the planetary stage's carrier, the ring is held, two parallel
// stages follow. Every speed and mesh frequency is the ratio chain's and Willis's (the
// parallel stages' at the sun's absolute speed, not at its speed relative to the carrier), the
// rotor's mean torque the reaction to the generator's 750 kW, printed and in summary.json, and
// the case draws no warning.
TEST(Cli, AWindTurbineGearboxRunsAtTheSpeedsOfItsRatioChain) {
  const fs::path d = fresh("wind_turbine");
  const Outcome o = cli("run " + case_path("wind_turbine_grc750.toml") +
                        " --set solver.duration_s=0.02 --out " + d.string());
  ASSERT_EQ(o.code, 0) << o.err;
  EXPECT_EQ(o.err.find("warning"), std::string::npos) << o.err;
  const double ratio = (1 + 99.0 / 21) * (82.0 / 23) * (88.0 / 22);  // 81.49
  const double carrier_hz = 30 / ratio, sun_hz = carrier_hz * (1 + 99.0 / 21);
  const nlohmann::json j = nlohmann::json::parse(slurp(d / "summary.json"));
  std::map<std::string, double> speed, mesh, torque;
  for (const auto& b : j["bodies"]) speed[b["name"]] = b["speed_hz"];
  for (const auto& m : j["meshes"]) mesh[m["name"]] = m["mesh_frequency_hz"];
  for (const auto& q : j["torques"]) torque[q["name"]] = q["mean_nm"];
  EXPECT_NEAR(speed["generator"], 30, 1e-12);
  EXPECT_NEAR(std::abs(speed["rotor"]) / carrier_hz, 1.0, 1e-14);
  EXPECT_NEAR(std::abs(speed["sun"]) / sun_hz, 1.0, 1e-14);
  EXPECT_EQ(speed["ring"], 0.0);
  EXPECT_NEAR(mesh["high_speed"] / 660, 1.0, 1e-14);
  EXPECT_NEAR(mesh["intermediate"] / (82 * sun_hz), 1.0, 1e-14);
  EXPECT_NEAR(mesh["planet_sun1"] / (99 * carrier_hz), 1.0, 1e-14);
  EXPECT_NEAR(mesh["ring_planet3"] / (99 * carrier_hz), 1.0, 1e-14);
  EXPECT_NEAR(torque["rotor"] / (3979 * ratio), 1.0, 1e-12);
  EXPECT_NE(o.out.find("speeds (rpm)      rotor 22.0884"), std::string::npos) << o.out;
  EXPECT_NE(o.out.find("mesh high_speed   660 Hz"), std::string::npos) << o.out;
  // Its meshes' common period (437 s) is too long for the exact engine's cells: the default
  // takes dopri5 and says why; the exact engine asked for is refused before any work.
  EXPECT_EQ(j["method"], "dopri5");
  EXPECT_NE(o.out.find("method            dopri5: chosen by the default: the exact engine would "
                       "cut the meshes' common period of 437.3 s"),
            std::string::npos)
      << o.out;
  const fs::path e = fresh("wind_turbine_exact");
  expect_refused(cli("run " + case_path("wind_turbine_grc750.toml") +
                     " --set solver.method=exact --out " + e.string()),
                 "more than the 65536 it can hold; use solver.method = \"dopri5\"");
  EXPECT_FALSE(fs::exists(e));
}

// The wind-turbine gearbox's Campbell diagram over its own speeds: the generator from rest to
// 1.5 times its 30 Hz, up to the high-speed mesh's third order there (3 x 22 x 45 Hz); a mode
// above every order in that range is not drawn (it was, outside the graph, when the speed axis
// ran to 4000 Hz to reach the modes with the planetary stage's slow orders). The rotor's
// torque has a third order (the blades passing the tower): its line is drawn, and the frequency
// axis is logarithmic down to a third of it at the operating speed, so that it shows below the
// drivetrain's first mode (3.1 Hz).
TEST(Cli, TheCampbellDiagramSpansTheCasesSpeeds) {
  const fs::path d = fresh("wind_turbine_campbell");
  const Outcome o = cli("modes " + case_path("wind_turbine_grc750.toml") + " --out " + d.string());
  ASSERT_EQ(o.code, 0) << o.err;
  const std::string body = slurp(d / "campbell_body.gp");
  EXPECT_NE(body.find("set xrange [0:45]"), std::string::npos) << body;
  EXPECT_NE(body.find("set logscale y"), std::string::npos) << body;
  const std::size_t range = body.find("set yrange [");
  ASSERT_NE(range, std::string::npos) << body;
  const double low = std::stod(body.substr(range + 12));
  EXPECT_NE(body.find(":3118.5]", range), std::string::npos) << body;  // 1.05 x 2970 Hz
  EXPECT_NE(body.find("title 'torque ''rotor'' order 3'"), std::string::npos) << body;
  // The rotor turns at the generator's 30 Hz over the gearbox's ratio.
  const nlohmann::json j = nlohmann::json::parse(
      cli("describe " + case_path("wind_turbine_grc750.toml") + " --json").out);
  double rotor_rpm = 0;
  for (const auto& b : j["bodies"])
    if (b["name"] == "rotor") rotor_rpm = b["speed_rpm"].get<double>();
  EXPECT_NEAR(low, 3 * rotor_rpm / 60 / 3, 1e-9 * low);
  EXPECT_EQ(body.find("set arrow from 0, 3220"), std::string::npos) << body;
  EXPECT_NE(body.find("title 'meshes planet_sun1 and 5 more order 1'"), std::string::npos) << body;
  fs::remove_all(d);
}

// `geardyn describe`: what the wind-turbine gearbox assembles to, before any run: each body's
// frame (the planetary stage's in its carrier's, the parallel stages' in the ground's) and
// speed, the pins where the gears put them (m_n (z_s + z_p) / (2 cos beta), written without a
// radius), the derived inertias, the shafts' damping coefficients, and no warning.
TEST(Cli, DescribeSaysWhatTheCaseAssemblesTo) {
  const std::string file = case_path("wind_turbine_grc750.toml");
  const Outcome o = cli("describe " + file + " --json");
  ASSERT_EQ(o.code, 0) << o.err;
  const nlohmann::json j = nlohmann::json::parse(o.out);
  std::map<std::string, nlohmann::json> body, bearing, shaft, mesh;
  for (const auto& b : j["bodies"]) body[b["name"]] = b;
  for (const auto& b : j["bearings"]) bearing[b["name"]] = b;
  for (const auto& s : j["shafts"]) shaft[s["name"]] = s;
  for (const auto& m : j["meshes"]) mesh[m["name"]] = m;
  EXPECT_EQ(body["planet2"]["frame"], "carrier");
  EXPECT_EQ(body["sun"]["frame"], "carrier");
  EXPECT_EQ(body["wheel1"]["frame"], "ground");
  EXPECT_EQ(mesh["ring_planet1"]["frame"], "carrier");
  EXPECT_EQ(mesh["high_speed"]["frame"], "ground");
  EXPECT_NEAR(body["generator"]["speed_rpm"].get<double>(), 1800, 1e-9);
  const double pin_m = 0.010 * (21 + 39) / (2 * std::cos(7.5 * std::numbers::pi / 180));
  EXPECT_NEAR(bearing["pin3"]["pin_radius_m"].get<double>(), pin_m, 1e-15);
  // A planet's blank: a cylinder of the reference diameter and face width, less its bore.
  const double d = 0.010 * 39 / std::cos(7.5 * std::numbers::pi / 180), di = 0.18, w = 0.2275;
  EXPECT_NEAR(body["planet1"]["mass_kg"].get<double>() /
                  (7850 * std::numbers::pi * w * (d * d - di * di) / 4),
              1.0, 1e-12);
  EXPECT_GT(shaft["main_shaft"]["damping_n_m_s_per_rad"].get<double>(), 0);
  EXPECT_GT(mesh["high_speed"]["static_force_n"].get<double>(), 0);
  EXPECT_TRUE(j["warnings"].empty()) << j["warnings"];
  const Outcome text = cli("describe " + file);
  ASSERT_EQ(text.code, 0) << text.err;
  EXPECT_NE(text.out.find("reference 'generator' at 30 Hz (1800 rpm)"), std::string::npos)
      << text.out;
}

// A train's spectra with --physical: each mesh's force in N and d - e in um, the normalised
// spectra times b k_m and b (the same run, the same samples).
TEST(Cli, ATrainsSpectraAreInPhysicalUnitsWhenAsked) {
  const std::string file = case_path("two_stage_reducer.toml");
  const fs::path bar = fresh("spectra_bar"), si = fresh("spectra_si");
  ASSERT_EQ(
      cli("run " + file + " --set solver.duration_s=0.02 --out " + bar.string() + " --plot").code,
      0);
  const Outcome o = cli("run " + file + " --set solver.duration_s=0.02 --out " + si.string() +
                        " --plot --physical");
  ASSERT_EQ(o.code, 0) << o.err;
  const CsvTable a = read_csv(bar / "train_spectrum.csv"), b = read_csv(si / "train_spectrum.csv");
  const nlohmann::json j = nlohmann::json::parse(slurp(si / "summary.json"));
  const double km = j["meshes"][1]["mean_stiffness_n_per_m"],
               backlash = j["meshes"][1]["backlash_m"];
  ASSERT_EQ(a.rows.size(), b.rows.size());
  const std::size_t f_bar = a.column("stage2_force_bar"), f_n = b.column("stage2_force_n"),
                    d_bar = a.column("stage2_deflection_bar"),
                    d_um = b.column("stage2_deflection_um");
  for (std::size_t k = 1; k < a.rows.size(); k += 17) {
    EXPECT_NEAR(std::stod(b.rows[k][f_n]), std::stod(a.rows[k][f_bar]) * backlash * km,
                1e-5 * std::stod(b.rows[k][f_n]));
    EXPECT_NEAR(std::stod(b.rows[k][d_um]), std::stod(a.rows[k][d_bar]) * backlash * 1e6,
                1e-5 * std::stod(b.rows[k][d_um]));
  }
  EXPECT_NE(slurp(si / "train_spectrum_body.gp").find("title 'F (N)'"), std::string::npos);
}

TEST(Cli, RunWritesSummaryTimeseriesAndEvents) {
  const fs::path d = fresh("run");
  const Outcome o = cli("run " + kCase + " --out " + d.string());
  ASSERT_EQ(o.code, 0) << o.err;
  EXPECT_NE(o.out.find("regime            sustained"), std::string::npos) << o.out;
  const nlohmann::json j = nlohmann::json::parse(slurp(d / "summary.json"));
  EXPECT_EQ(j["regime"], "sustained");
  EXPECT_GT(j["impacts"].get<int>(), 10);
  const std::string ts = slurp(d / "timeseries.csv");
  EXPECT_EQ(ts.substr(0, ts.find('\n')), "t_s,delta_bar,velocity_m_s,force_bar,contact");
  EXPECT_EQ(slurp(d / "events.csv").substr(0, 22), "t_s,kind,velocity_m_s\n");
  EXPECT_TRUE(fs::exists(d / "case.toml"));
}

TEST(Cli, SetOverridesAKey) {
  const fs::path d = fresh("set");
  const Outcome o =
      cli("run --set speed.shaft_frequency_hz=100 --set solver.duration_s=0.1 --out " + d.string());
  ASSERT_EQ(o.code, 0) << o.err;
  EXPECT_EQ(nlohmann::json::parse(slurp(d / "summary.json"))["regime"], "transient");
}

struct Bad {
  std::string args;
  std::vector<std::string> expect;
};

void PrintTo(const Bad& b, std::ostream* os) { *os << b.args; }

class CliBadInput : public ::testing::TestWithParam<Bad> {};

TEST_P(CliBadInput, ExitsWithTwoAndWritesNothing) {
  const fs::path d = fresh("bad");
  const Outcome o = cli(GetParam().args + " --out " + d.string());
  EXPECT_EQ(o.code, 2) << o.err;
  for (const std::string& s : GetParam().expect)
    EXPECT_NE(o.err.find(s), std::string::npos) << o.err;
  EXPECT_FALSE(fs::exists(d));
}

INSTANTIATE_TEST_SUITE_P(
    Cli, CliBadInput,
    ::testing::Values(Bad{"run --set mesh.backlash_um=-1",
                          {"--set mesh.backlash_um=-1", "mesh.backlash_um = -1",
                           "at least 0.001 um"}},
                      Bad{"run --set gear.inertia_kg_m2=[0,1]", {"gear.inertia_kg_m2[0]", "> 0"}},
                      Bad{"run --set solver.time_step_s=1",
                          {"solver.time_step_s = 1", "smaller than solver.duration_s"}},
                      Bad{"run --set mesh.backlash_um=nan", {"mesh.backlash_um = nan"}},
                      Bad{"run --set speed.rpm=3", {"unknown key 'speed.rpm'"}},
                      Bad{"run no/such/file.toml", {"no/such/file.toml", "cannot read"}},
                      Bad{"run --set gear.center_distance_mm=100",
                          {"gear.center_distance_mm = 100", "base radii"}},
                      Bad{"run --bogus", {"bogus"}}));

TEST(Cli, UnknownKeyInAFileNamesFileAndLine) {
  const fs::path dir = fresh("file");
  fs::create_directories(dir);
  std::ofstream(dir / "c.toml") << "[mesh]\nbacklash_um = 50\nstiffnes = 3\n";
  const Outcome o = cli("run " + (dir / "c.toml").string());
  expect_refused(o, "c.toml:3");
  EXPECT_NE(o.err.find("mesh.stiffnes"), std::string::npos) << o.err;
}

TEST(Cli, TheErrorPathSurvivesClosedAndFullStreams) {
  // stderr closed: the error is not printable, the exit code still says what happened (no
  // abort); stdout full: a failure, not success.
  EXPECT_EQ(cli("run --set mesh.backlash_um=-1 2>&-").code, 2);
  EXPECT_EQ(cli("run --set solver.duration_s=0.001 2>&-").code, 0);
  const Outcome full = cli("run --set solver.duration_s=0.001 >/dev/full");
  EXPECT_EQ(full.code, 1);
  EXPECT_NE(full.err.find("cannot write to standard output"), std::string::npos) << full.err;
}

// One row per kind of bad input (docs/case-files.md, "Bad inputs, tested"): the command, its
// exit code (2 bad input, 1 numerical failure or a failed write) and a piece of the message.
// Every row: no output directory written, no abort, the message on one short line.
struct BadInput {
  std::string args;
  int code;
  std::vector<std::string> message;  // pieces the message holds
};

std::vector<BadInput> bad_inputs(const fs::path& d) {
  const std::string nd = "--set model.form=nondimensional ";
  const std::string out = " --out " + (d / "out").string();
  return {
      // Counts and work.
      {"run --set solver.duration_s=1e9" + out, 2, {"solver.duration_s = 1e+09", "at most 1e+08"}},
      {"run --set solver.output_interval_s=1e-12" + out,
       2,
       {"solver.output_interval_s = 1e-12", "at most 5e+06"}},
      {"run --set solver.method=newmark --set solver.time_step_s=1e-300" + out,
       2,
       {"solver.time_step_s = 1e-300", "at most 1e+10"}},
      {"sweep " + nd +
           "--param model.omega --from 1 --to 2 --points 100000 --param2 "
           "model.force_alternating --from2 0 --to2 1 --points2 100000" +
           out,
       2,
       {"points in the map"}},
      {"sweep " + nd + "--param model.omega --from 1 --to 2 --points 0" + out,
       2,
       {"--points = 0: must be a whole number from 1 to 100000"}},
      {"sweep " + nd + "--param model.omega --from 1 --to 2 --points 3 --settle-periods -1" + out,
       2,
       {"--settle-periods = -1"}},
      {"stability --param speed.shaft_frequency_hz --from 10 --to 20 --points 0" + out,
       2,
       {"--points = 0"}},
      {"sweep --param speed.shaft_frequency_hz --from 1e-300 --to 1e-299 --points 3" + out,
       2,
       {"--from 1e-300 of speed.shaft_frequency_hz: a point runs up to",
        "periods of the case's fastest time scale"}},
      {"sweep --param speed.shaft_frequency_hz --from 100 --to 110 --points 2 --set "
       "solver.method=newmark --set solver.time_step_s=1e-15" +
           out,
       2,
       {"--from 100 of speed.shaft_frequency_hz: solver.time_step_s = 1e-15: a point runs up "
        "to 210 system periods",
        "Newmark steps", "at most 1e+10"}},
      {"sweep " + case_path("two_stage_reducer.toml") +
           " --param train.reference_speed_hz --from 100 --to 110 "
           "--points 2 --set solver.method=newmark --set solver.time_step_s=1e-15" +
           out,
       2,
       {"solver.time_step_s = 1e-15: a point runs up to", "Newmark steps", "at most 1e+10"}},
      {"run " + case_path("two_stage_reducer.toml") +
           " --set solver.method=newmark --set "
           "solver.time_step_s=1e-300" +
           out,
       2,
       {"solver.time_step_s = 1e-300", "Newmark steps over solver.duration_s", "at most 1e+10"}},
      {"sweep --param mesh.backlash_um --from 100 --to -5 --points 3" + out,
       2,
       {"--to -5", "mesh.backlash_um = -5"}},
      // Options that qualify nothing without their partner.
      {"sweep " + nd + "--param model.omega --from 1 --to 2 --points 3 --from2 0 --to2 1" + out,
       2,
       {"--from2", "--param2"}},
      {"sweep " + nd + "--param model.omega --from 1 --to 2 --points 3 --param2 model.zeta" + out,
       2,
       {"--param2", "--from2"}},
      {"stability --param speed.shaft_frequency_hz --from 80 --to 100 --points 3 --log2" + out,
       2,
       {"--log2", "--param2"}},
      {"continue " + nd + "--param model.omega --from 1 --to 2 --no-figures --overlay-sweep x" +
           out,
       2,
       {"--overlay-sweep", "--no-figures"}},
      // Steps the physics cannot resolve, readings that are not finite.
      {"run --set solver.method=newmark --set solver.time_step_s=1e-3" + out,
       2,
       {"solver.time_step_s = 0.001", "does not resolve the case's fastest time scale"}},
      {"run --set solver.time_step_s=1" + out, 2, {"smaller than solver.duration_s"}},
      {"run --set solver.method=dopri5 --set load.torque_nm=1e300 --set "
       "solver.duration_s=0.001" +
           out,
       1,
       {"non-finite readings"}},
      {"run --set mesh.backlash_um=1e-310" + out, 2, {"mesh.backlash_um = 1e-310"}},
      // Derived physics.
      {"run --set gear.normal_module_mm=1e-9" + out,
       2,
       {"with gear.normal_module_mm = 1e-09 (--set gear.normal_module_mm=1e-9): "
        "gear.outside_diameter_mm[0] = 154.98: the tooth comes to a point"}},
      {"run " + kCase + " --set gear.normal_module_mm=1e-9" + out,
       2,
       {"the tooth comes to a point",
        "park2010.toml:", "gear.normal_module_mm from --set gear.normal_module_mm=1e-9"}},
      {"run --set load.fluctuation_order=1e300" + out,
       2,
       {"load.fluctuation_order = 1e+300 (--set load.fluctuation_order=1e300): the torque's "
        "fluctuation sets the case's fastest time scale"}},
      {"run --set mesh.stiffness_source=table" + out,
       2,
       {"with mesh.stiffness_source = \"table\" (--set mesh.stiffness_source=table): ",
        "mesh.stiffness_table = \"\": must be a CSV file"}},
      {"run --set gear.face_width_mm=1e308" + out, 2, {"gear.face_width_mm = 1e+308"}},
      {"run --set gear.outside_diameter_mm=[300,300]" + out,
       2,
       {"gear.outside_diameter_mm[0] = 300: the tooth comes to a point"}},
      {"run --set gear.center_distance_mm=120" + out, 2, {"sum of the base radii"}},
      {"run --set gear.teeth=[3,3]" + out, 2, {"gear.teeth[0] = 3"}},
      {"run --set mesh.stiffness_source=table --set mesh.stiffness_table='\"" +
           (d / "steep.csv").string() + "\"'" + out,
       2,
       {"make the mesh stiffness negative"}},
      {"run --set mesh.stiffness_harmonics=[[0.6,0],[0.6,0]]" + out, 2, {"sum is < 1"}},
      {"orbit --set load.fluctuation_ratio=0 --set mesh.stiffness_source=harmonics",
       2,
       {"nothing in the model varies in time"}},
      // Keys and values.
      {"run --set mesh.backlash_um=-5" + out, 2, {"mesh.backlash_um = -5"}},
      {"run --set speed.rpm=3" + out, 2, {"unknown key 'speed.rpm'"}},
      {"run --set mesh.tension=pull" + out, 2, {"must be one of \"allow\" | \"clip\""}},
      {"continue --param solver.method --from 0 --to 1" + out,
       2,
       {"--param solver.method", "not a real number the model reads"}},
      {"continue --param model.zeta --from 0.05 --to -0.1" + out,
       2,
       {"--to -0.1", "model.zeta = -0.1", "[0, 1)"}},
      {"run --set mesh.backlash_um=-" + std::string(100000, '1') + out,
       2,
       {"mesh.backlash_um", "characters left out"}},
      // Files and channels.
      {"run " + d.string() + out, 2, {"must be a regular file, not a directory"}},
      {"run /dev/zero" + out, 2, {"not a device or pipe"}},
      {"run " + (d / "missing.toml").string() + out, 2, {"cannot read the case file"}},
      {"run " + (d / "nul.toml").string() + out, 2, {"a NUL character"}},
      {"run " + (d / "key.toml").string() + out, 2, {"a non-ASCII character outside a string"}},
      {"sweep " + nd + "--param model.omega --from 1 --to 2 --points 2 --out " +
           (d / "a_file").string(),
       2,
       {"exists and is not a directory"}},
      {"run --plot", 2, {"--plot: needs --out DIR"}},
      {"reproduce kahraman1990" + out, 2, {"unknown study"}},
      {"run --set solver.duration_s=0.001 >/dev/full", 1, {"cannot write to standard output"}},
  };
}

TEST(Cli, BadInputsAreRefusedWithTheirKeyAndNothingWritten) {
  const fs::path d = fresh("bad_inputs");
  fs::create_directories(d);
  {
    std::ofstream(d / "a_file") << "x";
    std::ofstream(d / "nul.toml", std::ios::binary) << std::string("[mesh\0]\n", 8);
    std::ofstream(d / "key.toml") << "[gear]\nmodule_\xce\xbcm = 2\n";
    std::ofstream steep(d / "steep.csv");
    steep << "position,stiffness_n_per_m\n0,1e8\n0.1,1e8\n";
    for (int i = 2; i <= 8; ++i) steep << "0." << i << ",1e5\n";
    steep << "0.9,1e8\n";
  }
  const std::vector<BadInput> rows = bad_inputs(d);
  EXPECT_GE(rows.size(), 30U);
  for (const BadInput& x : rows) {
    const Outcome o = cli(x.args);
    const std::string shown = x.args.substr(0, 120);
    EXPECT_EQ(o.code, x.code) << shown << "\n" << o.err.substr(0, 400);
    for (const std::string& piece : x.message)
      EXPECT_NE(o.err.find(piece), std::string::npos) << shown << "\n" << o.err.substr(0, 400);
    EXPECT_LT(o.err.size(), 1200U) << shown;
    EXPECT_FALSE(fs::exists(d / "out")) << shown;
    EXPECT_EQ(o.out.find("written to"), std::string::npos) << shown;  // no work was done
  }
}

TEST(Cli, ATrainWhoseTorqueOverflowsFailsNumericallyNotAsBadInput) {
  // The coupled pair runs as its train, whose free rotation is split off: a torque that
  // overflows (1e307 fluctuating 1e300 times over) made that split refuse the forcing as
  // "region 0 forces the free motion unlike region 0", exit 2. It is the run that fails, as the
  // one-degree run does: exit 1, why, nothing written.
  const fs::path d = fresh("diverge_train");
  const Outcome o = cli(std::string("run ") + GEARDYN_SOURCE_DIR +
                        "/cases/park2010_coupled.toml --set load.torque_nm=1e307 --set "
                        "load.fluctuation_ratio=1e300 --out " +
                        d.string());
  EXPECT_EQ(o.code, 1) << o.err;
  EXPECT_NE(o.err.find("numerical failure"), std::string::npos) << o.err;
  EXPECT_NE(o.err.find("non-finite"), std::string::npos) << o.err;
  EXPECT_FALSE(fs::exists(d));
}

TEST(Cli, NumericalFailureExitsWithOneAndTheReason) {
  const fs::path d = fresh("diverge");
  const Outcome o =
      cli("run --set load.torque_nm=1e307 --set load.fluctuation_ratio=1e300 --out " + d.string());
  EXPECT_EQ(o.code, 1) << o.err;
  EXPECT_NE(o.err.find("numerical failure"), std::string::npos) << o.err;
  EXPECT_NE(o.err.find("non-finite"), std::string::npos) << o.err;
  EXPECT_FALSE(fs::exists(d));
}

TEST(Cli, GeometryJson) {
  const Outcome o = cli("geometry --json");
  ASSERT_EQ(o.code, 0) << o.err;
  const nlohmann::json j = nlohmann::json::parse(o.out);
  EXPECT_NEAR(j["reference_diameter_mm"][0].get<double>(), 148.98, 0.005);
  EXPECT_NEAR(j["shift_center_distance_mm"].get<double>(), 150.0, 0.025);
  EXPECT_TRUE(j["warnings"].empty());
}

TEST(Cli, OrbitJsonReportsTheOrbitAndItsMultipliers) {
  // The Kahraman-Singh oscillator at Omega 0.95: a stable one-sided rattle, one impact a period.
  const Outcome o =
      cli("orbit --set model.form='\"nondimensional\"' --set model.force_alternating=0.02 "
          "--set model.omega=0.95 --json");
  ASSERT_EQ(o.code, 0) << o.err;
  const nlohmann::json j = nlohmann::json::parse(o.out);
  EXPECT_TRUE(j["converged"].get<bool>());
  EXPECT_NEAR(j["period_s"].get<double>(), 2 * 3.141592653589793 / 0.95, 1e-12);
  EXPECT_EQ(j["state"].size(), 2U);
  EXPECT_EQ(j["floquet_multipliers"].size(), 2U);
  EXPECT_TRUE(j["stable"].get<bool>());
  EXPECT_EQ(j["impacts_per_period"].get<int>(), 1);
  EXPECT_LT(j["min_delta_bar"].get<double>(), 1.0);
  EXPECT_GT(j["max_delta_bar"].get<double>(), 1.0);
  EXPECT_GT(j["max_force_bar"].get<double>(), 0.0);
}

TEST(Cli, OrbitWithoutExcitationIsBadInput) {
  const Outcome o =
      cli("orbit --set model.form='\"nondimensional\"' --set model.force_alternating=0");
  expect_refused(o, "nothing in the model varies in time");
}

TEST(Cli, ContinueWritesTheBranchTheBifurcationsAndTheFigure) {
  const fs::path d = fresh("continue");
  const Outcome o =
      cli("continue --set model.form='\"nondimensional\"' --set model.force_alternating=0.02 "
          "--param model.omega --from 0.5 --to 1.5 --out " +
          d.string());
  ASSERT_EQ(o.code, 0) << o.err;
  EXPECT_NE(o.out.find("fold"), std::string::npos) << o.out;
  EXPECT_NE(o.out.find("grazing"), std::string::npos) << o.out;
  const nlohmann::json b = nlohmann::json::parse(slurp(d / "bifurcations.json"));
  ASSERT_EQ(b.size(), 4U);
  EXPECT_EQ(b[1]["type"], "fold");
  EXPECT_TRUE(fs::exists(d / "branch.csv"));
  EXPECT_TRUE(fs::exists(d / "branch.png"));
  // The figure shows what happened: an unstable part and folds and grazings, nothing else.
  const std::string body = slurp(d / "branch_body.gp");
  EXPECT_NE(body.find("title 'unstable'"), std::string::npos);
  EXPECT_EQ(body.find("period_doubling"), std::string::npos);
  EXPECT_EQ(body.find("neimark_sacker"), std::string::npos);
  fs::remove_all(d);
}

TEST(Cli, ContinueDrawsASweepOverTheBranch) {
  const fs::path s = fresh("overlay_sweep"), d = fresh("overlay_branch");
  const std::string ks =
      "--set model.form='\"nondimensional\"' --set model.force_alternating=0.02 "
      "--param model.omega --from 0.5 --to 1.5 ";
  ASSERT_EQ(cli("sweep " + ks + "--points 21 --no-figures --out " + s.string()).code, 0);
  const Outcome o =
      cli("continue " + ks + "--out " + d.string() + " --overlay-sweep " + s.string());
  ASSERT_EQ(o.code, 0) << o.err;
  const std::string overlay = slurp(d / "overlay.csv");
  EXPECT_EQ(overlay.substr(0, overlay.find('\n')), "direction,value,x_a");
  const std::string body = slurp(d / "branch_body.gp");
  EXPECT_NE(body.find("title 'sweep up'"), std::string::npos);
  EXPECT_NE(body.find("title 'sweep down'"), std::string::npos);
  // A directory without sweep.csv is refused before any work, and nothing is written.
  const fs::path e = fresh("overlay_none");
  const Outcome bad =
      cli("continue " + ks + "--out " + e.string() + " --overlay-sweep " + d.string());
  expect_refused(bad, "no readable sweep.csv");
  EXPECT_FALSE(fs::exists(e));
  fs::remove_all(s);
  fs::remove_all(d);
}

TEST(Cli, ContinueRejectsATextKey) {
  const fs::path d = fresh("continue_bad");
  const Outcome o = cli("continue --param solver.method --from 0 --to 1 --out " + d.string());
  expect_refused(o, "--param solver.method");
  EXPECT_FALSE(fs::exists(d));
}

TEST(Cli, GeometryWarnsOnDisagreeingData) {
  const Outcome o = cli("geometry --set gear.center_distance_mm=151");
  EXPECT_EQ(o.code, 0);
  EXPECT_NE(o.err.find("warning: gear.center_distance_mm = 151"), std::string::npos) << o.err;
}

TEST(Cli, RunPlotDrawsTheFigures) {
  const fs::path d = fresh("plot");
  const Outcome o = cli("run --set solver.duration_s=0.01 --plot --out " + d.string());
  ASSERT_EQ(o.code, 0) << o.err;
  for (const char* f : {"run_time.png", "run_time.svg", "run_spectrum.png", "run_phase.png"})
    EXPECT_GT(fs::file_size(d / f), 100u) << f;
}

TEST(Cli, PlotNeedsAnOutputDirectory) {
  const Outcome o = cli("run --plot");
  expect_refused(o, "--plot: needs --out DIR");
}

TEST(Cli, ReproducePark2010) {
  const fs::path d = fresh("reproduce");
  const Outcome o = cli("reproduce park2010 --out " + d.string());
  ASSERT_EQ(o.code, 0) << o.err;
  EXPECT_NE(o.out.find("cases as the paper found"), std::string::npos) << o.out;
  EXPECT_TRUE(fs::exists(d / "report.html"));
  EXPECT_TRUE(fs::exists(d / "fig4.png"));
}

TEST(Cli, ReproduceSaysWhichSetItCannotUse) {
  // The study sets the backlash per case; --set mesh.backlash_um is not used and the command
  // says so (a --set the study leaves alone, here the damping form, is used silently).
  const fs::path d = fresh("reproduce_set");
  const Outcome o =
      cli("reproduce park2010 --no-figures --set mesh.backlash_um=250 --set "
          "mesh.damping=always --out " +
          d.string());
  ASSERT_EQ(o.code, 0) << o.err;
  EXPECT_NE(o.err.find("warning: --set mesh.backlash_um=250: the study sets mesh.backlash_um"),
            std::string::npos)
      << o.err;
  EXPECT_EQ(o.err.find("mesh.damping="), std::string::npos) << o.err;
}

TEST(Cli, ReproduceRejectsAnUnknownStudy) {
  const Outcome o = cli("reproduce kahraman1990");
  expect_refused(o, "unknown study");
}

TEST(Cli, StiffnessJsonAndFiles) {
  const fs::path d = fresh("stiffness");
  const Outcome o = cli("stiffness --json --out " + d.string());
  ASSERT_EQ(o.code, 0) << o.err;
  const nlohmann::json j = nlohmann::json::parse(o.out);
  for (const char* k : {"q_prime", "c_prime_th", "c_prime", "c_gamma_alpha", "c_gamma_beta"})
    EXPECT_TRUE(j["iso6336"].contains(k)) << k;
  for (const char* k :
       {"mean_n_per_m", "min_n_per_m", "max_n_per_m", "harmonics", "mean_pairs_in_contact"})
    EXPECT_TRUE(j["energy"].contains(k)) << k;
  EXPECT_EQ(j["energy"]["harmonics"].size(), 2u);
  EXPECT_TRUE(j["geometry"].contains("transverse_contact_ratio"));
  EXPECT_TRUE(j["geometry"].contains("overlap_ratio"));
  for (const char* f : {"stiffness.csv", "harmonics.json", "stiffness.png", "stiffness.svg"})
    EXPECT_GT(fs::file_size(d / f), 100u) << f;
  const std::string csv = slurp(d / "stiffness.csv");
  EXPECT_EQ(csv.substr(0, csv.find(',')), "position");
  // The curve a run uses: Table 1's k_m as its mean (the computed curve is scaled to it), and
  // the two kept harmonics; the energy method's own mean is larger.
  std::istringstream rows(csv);
  std::string row;
  std::getline(rows, row);
  EXPECT_EQ(row.substr(0, 58), "position,position_mm,total_n_per_m,series_n_per_m,used_n_p");
  double used = 0, total = 0;
  int n = 0;
  while (std::getline(rows, row)) {
    double x[5];
    ASSERT_EQ(std::sscanf(row.c_str(), "%lf,%lf,%lf,%lf,%lf", &x[0], &x[1], &x[2], &x[3], &x[4]),
              5);
    total += x[2];
    used += x[4];
    ++n;
  }
  ASSERT_GT(n, 10);
  EXPECT_NEAR(used / n, 2.34e8, 1e-6 * 2.34e8);
  EXPECT_GT(total / n, 1.2 * 2.34e8);
  EXPECT_NE(slurp(d / "stiffness_body.gp").find("title 'kept (2)'"), std::string::npos);
}

TEST(Cli, SweepWritesItsResults) {
  const fs::path d = fresh("sweep");
  const Outcome o =
      cli("sweep --set model.form='\"nondimensional\"' --set solver.initial='\"static\"' "
          "--param model.omega --from 0.3 --to 1.5 --points 31 --out " +
          d.string());
  ASSERT_EQ(o.code, 0) << o.err;
  EXPECT_NE(o.out.find("up sweep jumps"), std::string::npos) << o.out;
  const std::string csv = slurp(d / "sweep.csv");
  EXPECT_EQ(csv.substr(0, csv.find('\n')).substr(0, 26), "direction,param,value,para");
  EXPECT_GT(fs::file_size(d / "frequency_response.png"), 100u);
  EXPECT_GT(fs::file_size(d / "bifurcation.svg"), 100u);
}

TEST(Cli, ReadmeSweepShowsTheJump) {
  // The README's sweep as written: the up sweep starts from static contact and jumps off the
  // contact branch; started from the case's rest mid-backlash both sweeps rattle from the
  // start, and the command says that no jump was found.
  const fs::path d = fresh("readme_sweep");
  const std::string cmd =
      "sweep --param speed.shaft_frequency_hz --from 1500 --to 3500 --points 400 --no-figures "
      "--out " +
      d.string();
  const Outcome o = cli(cmd);
  ASSERT_EQ(o.code, 0) << o.err;
  EXPECT_NE(o.out.find("up sweep jumps between 2261.9 and 2266.92"), std::string::npos) << o.out;
  EXPECT_EQ(o.out.find("no jump found"), std::string::npos) << o.out;
  const Outcome rest = cli(cmd + " --start case");
  ASSERT_EQ(rest.code, 0) << rest.err;
  EXPECT_NE(rest.out.find("no jump found"), std::string::npos) << rest.out;
}

TEST(Cli, InterruptedSweepKeepsTheCompletedPoints) {
  // SIGINT (Ctrl-C) or SIGTERM (a polite kill: a batch system's) after a second, into a sweep
  // that takes far longer (Newmark at a fine step).
  for (const char* signal : {"INT", "TERM"}) {
    const fs::path d = fresh(std::string("sweep_int_") + signal);
    const Outcome o =
        cli("sweep --set solver.initial='\"static\"' --set solver.method='\"newmark\"' "
            "--set solver.time_step_s=1e-8 --param speed.shaft_frequency_hz "
            "--from 1000 --to 4000 --points 400 --out " +
            d.string() + " & pid=$!; sleep 1; kill -" + signal + " $pid; wait $pid");
    EXPECT_EQ(o.code, 130) << signal << o.err;
    EXPECT_NE(o.err.find("interrupted"), std::string::npos) << o.err;
    const std::string csv = slurp(d / "sweep.csv");
    EXPECT_GT(std::count(csv.begin(), csv.end(), '\n'), 1);  // header and some points
    const nlohmann::json j = nlohmann::json::parse(slurp(d / "summary.json"));
    EXPECT_TRUE(j["cancelled"].get<bool>());
  }
}

// A folder the user works in: a file, a folder with a file, and a file under one of our names in
// a sub-folder we do not write.
fs::path users_folder(const std::string& name) {
  const fs::path d = fresh(name);
  fs::create_directories(d / "src");
  fs::create_directories(d / "notes");
  std::ofstream(d / "thesis.tex") << "draft";
  std::ofstream(d / "src" / "a.c") << "code";
  std::ofstream(d / "notes" / "summary.json") << "the user's own";
  return d;
}

// The user's files are all there as they were, and nothing of ours is left half-done.
void expect_users_files(const fs::path& d, const std::string& what) {
  EXPECT_EQ(slurp(d / "thesis.tex"), "draft") << what;
  EXPECT_EQ(slurp(d / "src" / "a.c"), "code") << what;
  EXPECT_EQ(slurp(d / "notes" / "summary.json"), "the user's own") << what;
  for (const auto& e : fs::directory_iterator(d))
    EXPECT_EQ(e.path().filename().string().find(".geardyn-staging"), std::string::npos) << what;
}

TEST(Cli, EveryWritingCommandKeepsTheUsersFilesAndWritesIntoTheCurrentFolder) {
  // The issue's reproducer, for every command that writes: an output folder that holds the
  // user's files, written twice (the second run replaces our files), then as `--out .`.
  const std::string nd = "--set model.form=nondimensional ";
  const std::string coupled = case_path("park2010_coupled.toml");
  const std::string reducer = case_path("two_stage_reducer.toml");
  const std::string idler = case_path("idler_train.toml");
  const std::string loose = case_path("loose_gear_rattle.toml");
  const std::vector<std::pair<std::string, std::string>> commands = {
      {"run --set solver.duration_s=0.005 --plot", "run_time.png"},
      {"run " + coupled + " --set solver.duration_s=0.002 --plot", "train_time.png"},
      {"sweep " + nd + "--param model.omega --from 0.8 --to 1.2 --points 3", "sweep.csv"},
      {"continue " + nd +
           "--set model.force_alternating=0.02 --param model.omega --from 0.5 --to 0.6",
       "branch.csv"},
      {"stability --set mesh.stiffness_source=harmonics --set 'mesh.stiffness_harmonics=[[0.2,0]]' "
       "--param speed.shaft_frequency_hz --from 80 --to 100 --points 5",
       "stability.csv"},
      {"modes " + coupled, "modes.json"},
      {"run " + reducer + " --set solver.duration_s=0.002 --plot", "train_time.png"},
      {"modes " + reducer, "campbell.png"},
      {"sweep " + idler + " --param train.reference_speed_hz --from 40 --to 50 --points 2",
       "mesh_responses.png"},
      {"continue " + loose +
           " --param 'train.speed[0].acceleration_harmonics[0][0]' --from 200 --to 210",
       "branch.png"},
      {"stiffness", "stiffness.csv"},
      {"reproduce park2010 --no-figures", "report.html"},
  };
  for (const auto& [args, output] : commands) {
    const fs::path d = users_folder("keeps");
    for (int twice = 0; twice < 2; ++twice) {
      const Outcome o = cli(args + " --out " + d.string());
      ASSERT_EQ(o.code, 0) << args << "\n" << o.err;
      EXPECT_TRUE(fs::exists(d / output)) << args;
      expect_users_files(d, args);
    }
    const fs::path here = users_folder("dot");
    const Outcome o = shell("cd " + here.string() + " && " + GEARDYN_CLI + " " + args + " --out .");
    ASSERT_EQ(o.code, 0) << args << " --out .\n" << o.err;
    EXPECT_TRUE(fs::exists(here / output)) << args;
    expect_users_files(here, args + " --out .");
    fs::remove_all(d);
    fs::remove_all(here);
  }
}

TEST(Cli, AFailedWriteLeavesTheOutputFolderAsItWas) {
  // A folder of the user's under the name of one of our files: the run is done, nothing is
  // replaced, the error names the path, and the folder is as it was (the earlier run's files
  // included).
  const fs::path d = users_folder("failed_write");
  ASSERT_EQ(cli("run --set solver.duration_s=0.002 --out " + d.string()).code, 0);
  const std::string earlier = slurp(d / "summary.json");
  // A figure's name: the command looks for its data files' names alone before its work
  // (AFileOfTheUsersUnderOneOfOurNamesStopsTheCommandBeforeItsWork), so this is found at the
  // commit.
  fs::create_directories(d / "run_time.png");
  const Outcome o = cli("run --set solver.duration_s=0.003 --plot --out " + d.string());
  EXPECT_EQ(o.code, 1) << o.err;
  EXPECT_NE(o.err.find("run_time.png: cannot write: exists and is not a regular file"),
            std::string::npos)
      << o.err;
  EXPECT_EQ(slurp(d / "summary.json"), earlier);
  EXPECT_TRUE(fs::is_directory(d / "run_time.png"));
  expect_users_files(d, "failed write");
}

TEST(Cli, AFileOfTheUsersUnderOneOfOurNamesStopsTheCommandBeforeItsWork) {
  // A file the command would write, but the user's (never written by geardyn there): exit 2
  // before any work, naming the file, and the folder as it was, no manifest added. The same
  // file once the user changed it after geardyn wrote it.
  const std::string reducer = case_path("two_stage_reducer.toml");
  const std::vector<std::pair<std::string, std::string>> commands = {
      {"run --set solver.duration_s=0.002", "events.csv"},
      {"run " + reducer + " --set solver.duration_s=0.002", "timeseries.csv"},
      {"run " + reducer + " --set solver.duration_s=0.002", "events.csv"},
      {"sweep --set model.form=nondimensional --param model.omega --from 0.8 --to 1.2 --points 3",
       "strobe.csv"},
      {"continue --set model.form=nondimensional --set model.force_alternating=0.02 "
       "--param model.omega --from 0.5 --to 0.6",
       "branch.csv"},
      {"stability --param speed.shaft_frequency_hz --from 80 --to 100 --points 5",
       "boundaries.json"},
      {"modes " + reducer, "modes.json"},
      {"stiffness", "harmonics.json"},
      {"reproduce park2010 --no-figures", "study.json"},
      {"validate --quick", "validation.json"},
  };
  for (const auto& [args, name] : commands) {
    const fs::path d = users_folder("foreign");
    std::ofstream(d / name) << "the user's own";
    std::map<std::string, std::string> before;
    for (const auto& e : fs::recursive_directory_iterator(d))
      before[e.path().string()] = e.is_directory() ? "<dir>" : slurp(e.path());
    const Outcome o = cli(args + " --out " + d.string());
    expect_refused(o, "--out " + d.string() + ": " + name +
                          " there was not written by geardyn, or changed since it was");
    EXPECT_TRUE(o.out.empty()) << args << ": the work was done: " << o.out;
    std::map<std::string, std::string> after;
    for (const auto& e : fs::recursive_directory_iterator(d))
      after[e.path().string()] = e.is_directory() ? "<dir>" : slurp(e.path());
    EXPECT_EQ(after, before) << args;
    fs::remove_all(d);
  }
  // Written by geardyn, then changed by the user: theirs now.
  const fs::path d = users_folder("changed");
  ASSERT_EQ(cli("run --set solver.duration_s=0.002 --out " + d.string()).code, 0);
  std::ofstream(d / "case.toml", std::ios::app) << "# my notes\n";
  const std::string edited = slurp(d / "case.toml");
  expect_refused(cli("run --set solver.duration_s=0.002 --out " + d.string()),
                 "case.toml there was not written by geardyn, or changed since it was");
  EXPECT_EQ(slurp(d / "case.toml"), edited);
  fs::remove_all(d);
}

TEST(Cli, ACaseFileAsEditorsSaveItReadsAsTheSame) {
  // A byte-order mark (Windows editors), CRLF line ends and no newline at the end: the same case
  // as the plain file; and an error in such a file is still placed at its line.
  const fs::path d = fresh("editors");
  fs::create_directories(d);
  const std::string lines[] = {"description = \"edited\"", "[mesh]",
                               "backlash_um = 150   # a comment", "[speed]",
                               "shaft_frequency_hz = 100"};
  std::string plain, windows = "\xEF\xBB\xBF";
  for (const std::string& l : lines) {
    plain += l + "\n";
    windows += l + "\r\n";
  }
  windows.resize(windows.size() - 2);  // the last line without its line end
  std::ofstream(d / "plain.toml", std::ios::binary) << plain;
  std::ofstream(d / "windows.toml", std::ios::binary) << windows;
  const Outcome a = cli("run " + (d / "plain.toml").string() + " --set solver.duration_s=0.01");
  const Outcome b = cli("run " + (d / "windows.toml").string() + " --set solver.duration_s=0.01");
  ASSERT_EQ(a.code, 0) << a.err;
  ASSERT_EQ(b.code, 0) << b.err;
  const auto body = [](const std::string& out) { return out.substr(out.find('\n')); };
  EXPECT_EQ(body(a.out).substr(0, body(a.out).find("steps")),
            body(b.out).substr(0, body(b.out).find("steps")));
  std::ofstream(d / "bad.toml", std::ios::binary)
      << "\xEF\xBB\xBF[mesh]\r\nbacklash_um = 150\r\nstiffnes = 3";
  const Outcome bad = cli("run " + (d / "bad.toml").string());
  expect_refused(bad, "bad.toml:3:1: unknown key 'mesh.stiffnes'");
  // A stiffness table saved the same way gives the same stiffness as the plain one.
  const std::string rows[] = {"position,stiffness_n_per_m", "0,2.2e8", "0.25,2.5e8", "0.5,2.3e8",
                              "0.75,2.6e8"};
  std::string plain_csv, windows_csv = "\xEF\xBB\xBF";
  for (const std::string& r : rows) {
    plain_csv += r + "\n";
    windows_csv += r + " \r\n";  // a trailing blank too
  }
  windows_csv.resize(windows_csv.size() - 2);
  std::ofstream(d / "plain.csv", std::ios::binary) << plain_csv;
  std::ofstream(d / "windows.csv", std::ios::binary) << windows_csv;
  const auto run_with = [&](const char* file) {
    const Outcome o =
        cli("run --set solver.duration_s=0.01 --set mesh.stiffness_source=table "
            "--set mesh.stiffness_table='\"" +
            (d / file).string() + "\"'");
    EXPECT_EQ(o.code, 0) << file << o.err;
    return o.out.substr(0, o.out.find("steps"));
  };
  EXPECT_EQ(run_with("plain.csv"), run_with("windows.csv"));
  fs::remove_all(d);
}

TEST(Cli, ASettingTheMethodDoesNotUseIsReported) {
  // A Newmark step under the exact engine, [bearings] on the one-degree pair, [model] keys of
  // the non-dimensional form on the gear pair: each said on stderr with where it came from, and
  // listed in summary.json; a step that Newmark does use is not.
  const fs::path d = fresh("unused");
  const Outcome o =
      cli("run --set solver.time_step_s=1e-7 --set bearings.damping_ratio=0.1 --set model.omega=2 "
          "--set solver.duration_s=0.002 --out " +
          d.string());
  ASSERT_EQ(o.code, 0) << o.err;
  for (const char* piece :
       {"warning: solver.time_step_s = 1e-07 (--set solver.time_step_s=1e-7): not used: "
        "solver.method = \"exact\" chooses its own steps",
        "bearings.damping_ratio = 0.1 (--set bearings.damping_ratio=0.1): not used",
        "model.omega = 2.0 (--set model.omega=2): not used"})
    EXPECT_NE(o.err.find(piece), std::string::npos) << o.err;
  const nlohmann::json j = nlohmann::json::parse(slurp(d / "summary.json"));
  ASSERT_EQ(j["unused_settings"].size(), 3U) << j["unused_settings"];
  EXPECT_NE(j["unused_settings"][0].get<std::string>().find("model.omega"), std::string::npos);
  const Outcome used =
      cli("run --set solver.method=newmark --set solver.time_step_s=1e-7 --set "
          "solver.duration_s=0.002 --out " +
          d.string());
  ASSERT_EQ(used.code, 0) << used.err;
  EXPECT_EQ(used.err.find("not used"), std::string::npos) << used.err;
  EXPECT_TRUE(nlohmann::json::parse(slurp(d / "summary.json"))["unused_settings"].empty());
  // An orbit (as its continuation and a stability chart) is shot with the exact engine whatever
  // the method: the method and its step are said to be unused there, not dropped.
  const Outcome orbit =
      cli("orbit --set solver.method=newmark --set solver.time_step_s=1e-7 --set "
          "speed.shaft_frequency_hz=10");
  ASSERT_EQ(orbit.code, 0) << orbit.err;
  for (const char* piece :
       {"warning: solver.method = \"newmark\" (--set solver.method=newmark): not used: periodic "
        "orbits, their continuation and stability charts are computed with the exact engine",
        "warning: solver.time_step_s = 1e-07 (--set solver.time_step_s=1e-7): not used: periodic "
        "orbits"})
    EXPECT_NE(orbit.err.find(piece), std::string::npos) << orbit.err;
  // The shipped cases give nothing they do not use.
  for (const char* file : {"park2010.toml", "park2010_coupled.toml", "kahraman_singh.toml",
                           "two_stage_reducer.toml", "idler_train.toml", "loose_gear_rattle.toml",
                           "lin_parker_1999.toml", "planetary_set.toml"}) {
    const Outcome shipped = cli("run " + case_path(file) + " --set solver.duration_s=0.001");
    EXPECT_EQ(shipped.err.find("not used"), std::string::npos) << file << shipped.err;
  }
  fs::remove_all(d);
}

TEST(Cli, InterruptedRunKeepsWhatItComputed) {
  // SIGINT a second into a run of some fifteen seconds (Newmark at a fine step): the run stops
  // where it is, its samples up to there are read and written, summary.json says it was
  // cancelled, and the exit code is 130.
  const fs::path d = users_folder("run_int");
  const Outcome o = shell(std::string(GEARDYN_CLI) +
                          " run --set solver.method=newmark --set solver.time_step_s=1e-9 --set "
                          "solver.duration_s=0.15 --out " +
                          d.string() + " & pid=$!; sleep 1; kill -INT $pid; wait $pid");
  EXPECT_EQ(o.code, 130) << o.err;
  EXPECT_NE(o.err.find("interrupted"), std::string::npos) << o.err;
  const nlohmann::json j = nlohmann::json::parse(slurp(d / "summary.json"));
  EXPECT_EQ(j["termination"], "cancelled");
  const std::string ts = slurp(d / "timeseries.csv");
  const auto rows = std::count(ts.begin(), ts.end(), '\n') - 1;
  const double whole = 0.15 / j["derived"]["output_interval_s"].get<double>() + 1;
  EXPECT_GT(rows, 10);
  EXPECT_LT(static_cast<double>(rows), 0.5 * whole);  // a second of some fifteen
  expect_users_files(d, "interrupted run");
}

TEST(Cli, SweepRejectsABadKey) {
  const Outcome o = cli("sweep --param speed.rpm --from 1 --to 2 --points 3");
  expect_refused(o, "--param speed.rpm");
}

// A key the case does not read, in each study that varies one: refused, exit 2, nothing
// written (a train's sweep of [speed] once ran 400 identical points and said nothing).
TEST(Cli, AStudyOfAKeyTheCaseDoesNotReadIsRefused) {
  const std::string train = case_path("two_stage_reducer.toml");
  const fs::path d = fresh("unread_key");
  expect_refused(
      cli("sweep " + train +
          " --param speed.shaft_frequency_hz --from 100 --to 200 --points 3 --out " + d.string()),
      "--param speed.shaft_frequency_hz: the study would vary a key this case does "
      "not read: speed.shaft_frequency_hz = 100.0 (--from 100): not used: model.form "
      "= \"train\" reads [train] and [solver]");
  EXPECT_FALSE(fs::exists(d));
  expect_refused(
      cli("continue " + kCase + " --param model.zeta --from 0.01 --to 0.1 --out " + d.string()),
      "--param model.zeta: the continuation would vary a key this case does not read");
  EXPECT_FALSE(fs::exists(d));
  expect_refused(cli("stability " + kCase +
                     " --param bearings.radial_stiffness_n_per_m[0] --from 1e8 --to 2e8 "
                     "--points 3 --out " +
                     d.string()),
                 "has no bearings or shafts");
  EXPECT_FALSE(fs::exists(d));
}

TEST(Cli, LongRunShowsProgress) {
  // 1.5e8 steps: well over the one second after which progress is shown.
  const Outcome o =
      cli("run --set solver.method='\"newmark\"' --set solver.time_step_s=1e-9 "
          "--set solver.duration_s=0.15");
  ASSERT_EQ(o.code, 0) << o.err;
  EXPECT_NE(o.err.find("%"), std::string::npos) << o.err;
}

}  // namespace

TEST(Cli, KeyTablesInTheDocsAreTheProgramsOwn) {
  // docs/case-files.md holds, between its markers, what `geardyn keys --markdown` prints.
  const Outcome o = cli("keys --markdown");
  ASSERT_EQ(o.code, 0) << o.err;
  std::ifstream in(fs::path(GEARDYN_SOURCE_DIR) / "docs" / "case-files.md");
  std::stringstream text;
  text << in.rdbuf();
  const std::string doc = text.str();
  const std::string begin = "<!-- keys: begin (generated by geardyn keys --markdown) -->\n";
  const std::size_t a = doc.find(begin), b = doc.find("<!-- keys: end -->");
  ASSERT_NE(a, std::string::npos);
  ASSERT_NE(b, std::string::npos);
  EXPECT_EQ(doc.substr(a + begin.size(), b - a - begin.size()), o.out)
      << "regenerate the tables with: geardyn keys --markdown";
  EXPECT_NE(o.out.find("| backlash_um | um | 100.0 |"), std::string::npos);
  const Outcome j = cli("keys --json");
  ASSERT_EQ(j.code, 0) << j.err;
  const nlohmann::json keys = nlohmann::json::parse(j.out);
  EXPECT_GE(keys.size(), 45U);
  EXPECT_EQ(keys[1]["key"], "model.form");
}

// " --state v1 v2 ...": an orbit's values from its JSON, given back to the command line (each
// to the digits that read back to the same double).
std::string state_option(const nlohmann::json& values) {
  std::string out = " --state";
  for (const auto& x : values) out += fmt::format(" {:.17g}", x.get<double>());
  return out;
}

TEST(Cli, TheCoupledModelsOrbitIsFoundAndReported) {
  // The shipped case at its 1 kHz: a stable period-1 orbit in permanent contact (docs/orbits.md),
  // found on its train (train_form_of) as every train's orbit: its JSON a train's, the unknowns
  // the 11 coordinates and rates modulo the rigid rotation (22 multipliers, as the coupled
  // model's), the state every body's (24); a --state of the wrong size is named.
  const std::string coupled = case_path("park2010_coupled.toml");
  const Outcome o = cli("orbit " + coupled + " --json");
  ASSERT_EQ(o.code, 0) << o.err;
  const nlohmann::json j = nlohmann::json::parse(o.out);
  for (const char* key : {"converged", "period_s", "state", "unknowns", "coordinates",
                          "floquet_multipliers", "stable", "meshes", "clearances"})
    EXPECT_TRUE(j.contains(key)) << key;
  EXPECT_EQ(j["model"], "train");
  EXPECT_TRUE(j["modulo_rotation"].get<bool>());
  EXPECT_TRUE(j["converged"].get<bool>());
  EXPECT_TRUE(j["stable"].get<bool>());
  ASSERT_EQ(j["meshes"].size(), 1U);
  EXPECT_EQ(j["meshes"][0]["impacts_per_period"], 0);
  EXPECT_NEAR(j["max_multiplier"].get<double>(), 0.956, 0.0005);
  EXPECT_EQ(j["state"].size(), 24U);
  EXPECT_EQ(j["unknowns"].size(), 22U);
  EXPECT_EQ(j["floquet_multipliers"].size(), 22U);
  // The mesh never leaves contact.
  EXPECT_GT(j["meshes"][0]["min_deflection_bar"].get<double>(), 1.0);
  const Outcome text = cli("orbit " + coupled + " --set model.dof=3");
  ASSERT_EQ(text.code, 0) << text.err;
  EXPECT_NE(text.out.find("stable            no"), std::string::npos) << text.out;
  EXPECT_NE(text.out.find("2 impacts/period"), std::string::npos) << text.out;
  // Its stability in permanent contact: the default case has no tongue over 20-200 Hz.
  const Outcome st = cli("stability " + coupled +
                         " --set model.dof=3 --param speed.shaft_frequency_hz --from 20 --to 200 "
                         "--points 19 --json");
  ASSERT_EQ(st.code, 0) << st.err;
  EXPECT_EQ(nlohmann::json::parse(st.out)["boundaries"].size(), 0U);
  // A start of its six unknowns is taken; of two, refused by name.
  const nlohmann::json o3 =
      nlohmann::json::parse(cli("orbit " + coupled + " --set model.dof=3 --json").out);
  const Outcome from = cli("orbit " + coupled + " --set model.dof=3 --settle-periods 0 --json" +
                           state_option(o3["unknowns"]));
  ASSERT_EQ(from.code, 0) << from.err;
  EXPECT_LE(nlohmann::json::parse(from.out)["iterations"].get<int>(), 1);
  const Outcome bad = cli("orbit " + coupled + " --set model.dof=3 --state 0 0");
  EXPECT_NE(bad.code, 0);
  EXPECT_NE(bad.err.find("2 values given; this train takes 6"), std::string::npos) << bad.err;
}

TEST(Cli, TheCoupledModelRunsAndPrintsItsModes) {
  const std::string coupled = case_path("park2010_coupled.toml");
  // Its modes are its train's (train_form_of; the coupled model's to 1e-9 beside the rigid
  // rotation: TrainCase.TheCoupledFormsTrainHasTheCoupledPairsModesAndCoordinates): 12 at dof
  // 12, the first the rigid rotation at 0 Hz. Each elastic mode's strain energy is whole over
  // the mesh and the bearings, and each bearing's over its directions; the mesh-critical mode
  // (the last, 3656 Hz) holds 94 % in the mesh and strains no bearing across the line of action
  // (x) or about it (tilt x), which a frictionless mesh at one point does not touch.
  const Outcome m = cli("modes " + coupled + " --json");
  ASSERT_EQ(m.code, 0) << m.err;
  const nlohmann::json j = nlohmann::json::parse(m.out);
  ASSERT_EQ(j["modes"].size(), 12U);
  EXPECT_EQ(j["modes"][0]["frequency_hz"].get<double>(), 0.0);
  EXPECT_EQ(j["damped_eigenvalues"].size(), 11U);  // the rigid rotation's left out
  double last = 0;
  for (std::size_t k = 1; k < 12; ++k) {
    const nlohmann::json& mode = j["modes"][k];
    EXPECT_GE(mode["frequency_hz"].get<double>(), last);
    last = mode["frequency_hz"].get<double>();
    double sum = mode["mesh_energy"]["mesh"].get<double>();
    for (const char* bearing : {"pinion_bearing", "wheel_bearing"}) {
      double parts = 0;
      for (const auto& [direction, e] : mode["bearing_energy_parts"][bearing].items())
        parts += e.get<double>();
      EXPECT_NEAR(parts, mode["bearing_energy"][bearing].get<double>(), 1e-15) << k;
      sum += parts;
    }
    EXPECT_NEAR(sum, 1.0, 1e-12) << k;
  }
  const nlohmann::json& critical = j["modes"][11];
  EXPECT_NEAR(critical["frequency_hz"].get<double>(), 3656.28, 0.01);
  EXPECT_NEAR(critical["mesh_energy"]["mesh"].get<double>(), 0.939, 1e-3);
  for (const char* bearing : {"pinion_bearing", "wheel_bearing"}) {
    EXPECT_LT(critical["bearing_energy_parts"][bearing]["x"].get<double>(), 1e-20);
    EXPECT_LT(critical["bearing_energy_parts"][bearing]["tilt_x"].get<double>(), 1e-20);
    EXPECT_GT(critical["bearing_energy_parts"][bearing]["tilt_y"].get<double>(), 1e-3);
  }
  const Outcome table = cli("modes " + coupled);
  ASSERT_EQ(table.code, 0) << table.err;
  EXPECT_NE(table.out.find("(coupled, dof 12, as a train)"), std::string::npos) << table.out;
  EXPECT_NE(table.out.find("strain energy"), std::string::npos);

  // A coupled case runs as its train form (TrainSolver): the train's reading and files, the
  // case and its form as given.
  const fs::path d = fresh("coupled_run");
  const Outcome r = cli("run " + coupled + " --set solver.duration_s=0.005 --out " + d.string());
  ASSERT_EQ(r.code, 0) << r.err;
  EXPECT_NE(r.out.find("(coupled, dof 12, as a train: 2 bodies, 1 mesh)"), std::string::npos)
      << r.out;
  const nlohmann::json s = nlohmann::json::parse(slurp(d / "summary.json"));
  EXPECT_EQ(s["form"], "coupled");
  EXPECT_EQ(s["dof"], 12);
  EXPECT_GT(s["meshes"][0]["impacts"].get<int>(), 0);
  EXPECT_GT(s["meshes"][0]["dynamic_factor"].get<double>(), 1.0);
  ASSERT_EQ(s["bearings"].size(), 2U);
  EXPECT_FALSE(s["bearings"][0].contains("clearance_x"));
  // Along the line of action (y) and the axis the static load has a factor; across it, none.
  EXPECT_TRUE(s["bearings"][0]["dynamic_factor"]["force_x_n"].is_null());
  EXPECT_GT(s["bearings"][0]["dynamic_factor"]["force_y_n"].get<double>(), 1.0);
  EXPECT_GT(s["bearings"][0]["dynamic_factor"]["axial_force_n"].get<double>(), 1.0);
  // The terminal lists each bearing's factors as the summary has them, to 4 digits: along y,
  // the axis and about y, none across the line of action.
  for (const auto& b : s["bearings"]) {
    const nlohmann::json& f = b["dynamic_factor"];
    const std::string line = fmt::format("bearing {:<9} force x", b["name"].get<std::string>());
    const std::size_t at = r.out.find(line);
    ASSERT_NE(at, std::string::npos) << r.out;
    const std::string rest = r.out.substr(at, r.out.find('\n', at) - at);
    EXPECT_NE(rest.find(fmt::format(", dynamic factor y {:.4g}, axial {:.4g}, moment y {:.4g}",
                                    f["force_y_n"].get<double>(), f["axial_force_n"].get<double>(),
                                    f["moment_y_nm"].get<double>())),
              std::string::npos)
        << rest;
  }
  const std::string header = read_csv(d / "timeseries.csv").header;
  EXPECT_EQ(header.rfind("t_s,pinion_rad,wheel_rad,pinion_x_m,pinion_y_m,pinion_z_m", 0), 0U)
      << header;
  EXPECT_NE(header.find("mesh_deflection_bar,mesh_force_n,mesh_contact,pinion_bearing_force_x_n"),
            std::string::npos);
  EXPECT_NE(slurp(d / "case.toml").find("form = \"coupled\""), std::string::npos);
  fs::remove_all(d);

  // The figure, and a load shaft alone: its torque in the summary, the files and the figure.
  const Outcome shaft = cli("run " + coupled +
                            " --set 'shafts.end_inertia_kg_m2=[0, 0.3]' --set "
                            "solver.duration_s=0.005 --plot --out " +
                            d.string());
  ASSERT_EQ(shaft.code, 0) << shaft.err;
  EXPECT_NE(shaft.out.find("shaft load_shaft"), std::string::npos) << shaft.out;
  const nlohmann::json sj = nlohmann::json::parse(slurp(d / "summary.json"));
  ASSERT_EQ(sj["shafts"].size(), 1U);
  EXPECT_EQ(sj["shafts"][0]["name"], "load_shaft");
  // -R2 T1 / R1: the shaft's torque is positive when its first body (the wheel) leads.
  EXPECT_NEAR(sj["shafts"][0]["static_torque_nm"].get<double>(), -49.5, 1e-9);
  EXPECT_LT(sj["shafts"][0]["min_torque_nm"].get<double>(), -49.5);
  EXPECT_GT(sj["shafts"][0]["dynamic_factor"]["torque_nm"].get<double>(), 1.0);
  EXPECT_EQ(sj["coordinates"][2], "load_rad");
  const std::string shaft_header = read_csv(d / "timeseries.csv").header;
  EXPECT_NE(shaft_header.find(",load_shaft_torque_nm"), std::string::npos);
  EXPECT_EQ(shaft_header.find("drive_shaft"), std::string::npos);
  const std::string shaft_plot = slurp(d / "train_time_body.gp");
  EXPECT_NE(shaft_plot.find("shaft load_shaft"), std::string::npos);
  EXPECT_EQ(shaft_plot.find("drive_shaft"), std::string::npos);
  // dof 12: the helical mesh's thrust moves the gears along their axis, its own panel last.
  EXPECT_NE(shaft_plot.find("axial bearing forces"), std::string::npos);
  EXPECT_NE(read_csv(d / "train_plot.csv").header.find("wheel_bearing_axial_force_n"),
            std::string::npos);
  fs::remove_all(d);
  ASSERT_EQ(cli("run " + coupled +
                " --set model.dof=3 --set solver.duration_s=0.005 --plot --out " + d.string())
                .code,
            0);
  EXPECT_EQ(slurp(d / "train_time_body.gp").find("axial"), std::string::npos);
  fs::remove_all(d);
  const Outcome one = cli("run " + case_path("park2010.toml") +
                          " --set 'shafts.end_inertia_kg_m2=[0.1, 0]' --out " + d.string());
  EXPECT_NE(one.code, 0);
  EXPECT_NE(one.err.find("shafts.end_inertia_kg_m2[0] = 0.1"), std::string::npos) << one.err;
  EXPECT_NE(one.err.find("model.form = \"coupled\""), std::string::npos) << one.err;
  EXPECT_FALSE(fs::exists(d));

  ASSERT_EQ(cli("modes " + coupled + " --out " + d.string()).code, 0);
  EXPECT_TRUE(fs::exists(d / "campbell.png"));
  EXPECT_TRUE(fs::exists(d / "modes.json"));
  const std::string campbell = slurp(d / "campbell.csv");
  EXPECT_EQ(std::count(campbell.begin(), campbell.end(), '\n'), 1 + 12 * 3);
  const std::string body = slurp(d / "campbell_body.gp");
  EXPECT_NE(body.find("title 'resonance speed'"), std::string::npos);
  EXPECT_NE(body.find("title 'other mode'"), std::string::npos);  // x and the rocking tilts
  fs::remove_all(d);

  // A sweep takes it (the jump of its first mode, tests in sweep_test).
  const Outcome sw = cli("sweep " + coupled +
                         " --param bearings.radial_stiffness_n_per_m --from "
                         "5e8 --to 1e9 --points 2 --no-figures --out " +
                         d.string());
  ASSERT_EQ(sw.code, 0) << sw.err;
  EXPECT_TRUE(fs::exists(d / "sweep.csv"));
  fs::remove_all(d);
  // A continuation takes it too: branch.csv's state columns are its train's unknowns (modulo
  // the rigid rotation: the wheel's angle and each gear's centre along the line, then rates).
  const Outcome s1 = cli("continue " + coupled +
                         " --set model.dof=3 --set load.fluctuation_ratio=0 --set "
                         "mesh.transmission_error_um=[[1.0,0.0]] --param speed.shaft_frequency_hz "
                         "--from 900 --to 902 --no-figures --out " +
                         d.string());
  ASSERT_EQ(s1.code, 0) << s1.err;
  const std::string branch = slurp(d / "branch.csv");
  EXPECT_NE(branch.find(",separations_per_period,wheel_rad,pinion_line_m,wheel_line_m,wheel_rad_s,"
                        "pinion_line_m_s,wheel_line_m_s,mu1_re,"),
            std::string::npos)
      << branch.substr(0, 300);
  fs::remove_all(d);
  // The one-degree pair's modes are its train's: the rigid rotation and the contact mode, at the
  // natural frequency its run prints.
  const Outcome plain = cli("modes");
  ASSERT_EQ(plain.code, 0) << plain.err;
  EXPECT_NE(plain.out.find("(gear pair, as a train)"), std::string::npos) << plain.out;
  // The non-dimensional form's, in its units, said so.
  const Outcome tau = cli("modes --set model.form='\"nondimensional\"'");
  ASSERT_EQ(tau.code, 0) << tau.err;
  EXPECT_NE(tau.out.find("(non-dimensional, as a train: a second is a tau, Hz are cycles per tau)"),
            std::string::npos)
      << tau.out;
  const Outcome run = cli("run");
  ASSERT_EQ(run.code, 0) << run.err;
  const std::size_t at = run.out.find("contact natural frequency ");
  ASSERT_NE(at, std::string::npos) << run.out;
  const std::string f = run.out.substr(at + 26, run.out.find(' ', at + 26) - at - 26);
  EXPECT_NE(plain.out.find("   2 " + std::string(16 - f.size() - 1, ' ') + f + "     1   0.0200"),
            std::string::npos)
      << f << "\n"
      << plain.out;
  EXPECT_FALSE(fs::exists(d));
}

namespace {

TEST(Cli, ATrainRunReadsEachMeshAndItsCaseTomlRunsTheSame) {
  // The two-stage reducer: one reading per mesh by name in summary.json, every mesh's columns
  // in timeseries.csv, and case.toml that runs to the same readings.
  const std::string reducer = case_path("two_stage_reducer.toml");
  const fs::path d = users_folder("train_run");
  const Outcome o =
      cli("run " + reducer + " --set solver.duration_s=0.01 --plot --out " + d.string());
  ASSERT_EQ(o.code, 0) << o.err;
  EXPECT_NE(o.out.find("mesh stage2"), std::string::npos) << o.out;
  // 10 ms hold no whole system period (26.5 ms): no distance to a steady state is predicted,
  // and the line says why rather than "distance inf b".
  EXPECT_NE(o.out.find("not reached in the window (no decay seen over its system periods"),
            std::string::npos)
      << o.out;
  // The figure has a row per mesh, each drawing its own columns of train_plot.csv, and a row
  // for the shafts' torques.
  const std::string body = slurp(d / "train_time_body.gp");
  EXPECT_NE(body.find("layout 3,1"), std::string::npos) << body;
  EXPECT_NE(body.find("mesh stage2 (716.393 Hz)"), std::string::npos) << body;
  EXPECT_NE(body.find("using 1:4 skip 1 axes x1y1"), std::string::npos) << body;
  EXPECT_NE(body.find("using 1:8 skip 1 axes x1y1 with lines lw 1.2 lc rgb '#2e8b57' title "
                      "'shaft half_shafts (N m)'"),
            std::string::npos)
      << body;
  EXPECT_EQ(slurp(d / "train_plot.csv")
                .rfind("t_ms,stage1_deflection_bar,stage1_force_n,stage2_deflection_bar,"
                       "stage2_force_n,rotor_shaft_torque_nm,intermediate_torque_nm,"
                       "half_shafts_torque_nm\n0,",
                       0),
            0U);
  // The spectra: a row per mesh, each drawing its own columns of train_spectrum.csv with its
  // orders marked.
  const std::string spectrum = slurp(d / "train_spectrum_body.gp");
  EXPECT_NE(spectrum.find("layout 2,1"), std::string::npos) << spectrum;
  EXPECT_NE(spectrum.find("set title \"mesh stage2 (716.393 Hz)\""), std::string::npos);
  EXPECT_NE(spectrum.find("using 1:(($4>0)?$4:NaN)"), std::string::npos) << spectrum;
  EXPECT_NE(spectrum.find("set arrow from 2300, graph 0"), std::string::npos) << spectrum;
  EXPECT_EQ(read_csv(d / "train_spectrum.csv").header,
            "frequency_hz,stage1_force_bar,stage1_deflection_bar,stage2_force_bar,"
            "stage2_deflection_bar");
  EXPECT_GT(fs::file_size(d / "train_spectrum.png"), 100U);
  const nlohmann::json j = nlohmann::json::parse(slurp(d / "summary.json"));
  EXPECT_EQ(j["form"], "train");
  // The phase portraits: a panel per mesh, each drawing train_phase.csv's columns of its own
  // (d - e) / b against its own d' - e': the run's first samples, then the steady part's last
  // ones, each as timeseries.csv has them, at most 5000 of each.
  const CsvTable series = read_csv(d / "timeseries.csv");
  std::size_t steady_row = 0;
  while (std::stod(series.rows[steady_row][0]) < j["steady"]["from_s"].get<double>()) ++steady_row;
  const std::string phase = slurp(d / "train_phase_body.gp");
  EXPECT_NE(phase.find("layout 1,2"), std::string::npos) << phase;
  const std::string phase_csv = slurp(d / "train_phase.csv");
  const std::size_t gap = phase_csv.find("\n\n");
  ASSERT_NE(gap, std::string::npos);
  const std::size_t first_rows = static_cast<std::size_t>(
      std::count(phase_csv.begin(), phase_csv.begin() + static_cast<std::ptrdiff_t>(gap), '\n'));
  // Two blank lines between the blocks (gnuplot's index), each row after its line break, the
  // file ending with one.
  const std::size_t last_rows =
      static_cast<std::size_t>(std::count(phase_csv.begin() + static_cast<std::ptrdiff_t>(gap) + 2,
                                          phase_csv.end(), '\n')) -
      1;
  EXPECT_EQ(first_rows, std::min<std::size_t>(series.rows.size(), 5000));
  EXPECT_EQ(last_rows, std::min<std::size_t>(series.rows.size() - steady_row, 5000));
  // Its last row is timeseries.csv's, column by column.
  const std::string tail = phase_csv.substr(phase_csv.rfind('\n', phase_csv.size() - 2) + 1);
  for (const std::string mesh : {"stage1", "stage2"}) {
    const std::size_t column = mesh == "stage1" ? 2 : 4;
    EXPECT_NE(phase.find(fmt::format("set title \"mesh {}\" font ',10'\nplot 'train_phase.csv' "
                                     "index 0 every ::1 using {}:{} with lines",
                                     mesh, column, column + 1)),
              std::string::npos)
        << mesh << "\n"
        << phase;
    EXPECT_NE(
        phase.find(fmt::format("'' index 1 using {}:{} with lines lw 1.2", column, column + 1)),
        std::string::npos)
        << mesh << "\n"
        << phase;
    std::vector<std::string> cells;
    std::stringstream row(tail);
    for (std::string cell; std::getline(row, cell, ',');) cells.push_back(cell);
    ASSERT_EQ(cells.size(), 5u) << tail;
    EXPECT_NEAR(std::stod(cells[column - 1]),
                std::stod(series.rows.back()[series.column(mesh + "_deflection_bar")]), 1e-9);
    EXPECT_NEAR(std::stod(cells[column]),
                std::stod(series.rows.back()[series.column(mesh + "_deflection_rate_m_s")]),
                1e-9 * (1 + std::abs(std::stod(cells[column]))));
  }
  EXPECT_GT(fs::file_size(d / "train_phase.png"), 100U);
  ASSERT_EQ(j["meshes"].size(), 2U);
  EXPECT_EQ(j["meshes"][0]["name"], "stage1");
  EXPECT_EQ(j["meshes"][1]["name"], "stage2");
  EXPECT_NEAR(j["meshes"][0]["mesh_frequency_hz"].get<double>(), 2300.0, 1e-9);
  EXPECT_NEAR(j["meshes"][1]["mesh_frequency_hz"].get<double>(), 100.0 * 23 / 61 * 19, 1e-9);
  // Each mesh's k_m and backlash as the case gives them, in the summary and on the terminal.
  EXPECT_EQ(j["meshes"][0]["mean_stiffness_n_per_m"].get<double>(), 6e8);
  EXPECT_EQ(j["meshes"][1]["mean_stiffness_n_per_m"].get<double>(), 8e8);
  EXPECT_NEAR(j["meshes"][0]["backlash_m"].get<double>(), 30e-6, 1e-18);
  EXPECT_NEAR(j["meshes"][1]["backlash_m"].get<double>(), 40e-6, 1e-18);
  EXPECT_NE(o.out.find("mean stiffness 8e+08 N/m, backlash 40 um"), std::string::npos) << o.out;
  for (const auto& m : j["meshes"]) {
    EXPECT_GT(m["dynamic_factor"].get<double>(), 0.9) << m;
    EXPECT_GE(m["dynamic_factor_with_startup"].get<double>(), m["dynamic_factor"].get<double>());
  }
  const std::string ts = slurp(d / "timeseries.csv");
  EXPECT_NE(ts.substr(0, ts.find('\n')).find("stage2_force_n"), std::string::npos);
  expect_users_files(d, "train run");
  const fs::path again = fresh("train_again");
  const Outcome o2 = cli("run " + (d / "case.toml").string() + " --out " + again.string());
  ASSERT_EQ(o2.code, 0) << o2.err;
  const nlohmann::json j2 = nlohmann::json::parse(slurp(again / "summary.json"));
  EXPECT_EQ(j2["meshes"], j["meshes"]);
  fs::remove_all(d);
  fs::remove_all(again);
  // The paper's Newmark-beta on the train: the same readings to its step's accuracy, said to be
  // steps; a step that does not resolve the train is refused naming where it came from, exit
  // 2, nothing written.
  const fs::path nm = fresh("train_newmark");
  const Outcome o3 =
      cli("run " + reducer + " --set solver.duration_s=0.01 --set solver.method=newmark --out " +
          nm.string());
  ASSERT_EQ(o3.code, 0) << o3.err;
  EXPECT_NE(o3.out.find("  steps             "), std::string::npos) << o3.out;
  const nlohmann::json j3 = nlohmann::json::parse(slurp(nm / "summary.json"));
  EXPECT_EQ(j3["method"], "newmark");
  for (std::size_t m = 0; m < 2; ++m)
    EXPECT_NEAR(j3["meshes"][m]["max_force_n"].get<double>(),
                j["meshes"][m]["max_force_n"].get<double>(),
                1e-3 * j["meshes"][m]["max_force_n"].get<double>())
        << m;
  fs::remove_all(nm);
  const Outcome coarse =
      cli("run " + reducer + " --set solver.method=newmark --set solver.time_step_s=1e-3 --out " +
          nm.string());
  EXPECT_EQ(coarse.code, 2) << coarse.err;
  EXPECT_NE(coarse.err.find("solver.time_step_s = 0.001: does not resolve the train's fastest "
                            "time scale"),
            std::string::npos)
      << coarse.err;
  EXPECT_NE(coarse.err.find("--set solver.time_step_s=1e-3"), std::string::npos) << coarse.err;
  EXPECT_FALSE(fs::exists(nm));
}

// An internal mesh's stiffness is its pinion's in its ring: the wind-turbine gearbox's ring mesh
// (a planet of 39 teeth in a ring of 99, module 10 mm, 20 degrees, helix 7.5 degrees) gives ISO
// 6336-1's k_m the train runs with (describe), the internal pair's contact ratio by ISO 21771's
// closed form, and the energy method of the ring's concave teeth within ISO's scatter; its
// figure is drawn. Its geometry, no external pair's, is refused, pointing to stiffness.
TEST(Cli, AnInternalMeshsStiffnessIsItsPinionInItsRing) {
  const std::string wt = case_path("wind_turbine_grc750.toml");
  const Outcome s = cli("stiffness " + wt + " --mesh ring_planet1 --json");
  ASSERT_EQ(s.code, 0) << s.err;
  const nlohmann::json j = nlohmann::json::parse(s.out);
  const Outcome d = cli("describe " + wt + " --json");
  ASSERT_EQ(d.code, 0) << d.err;
  double train_k = 0;
  const nlohmann::json described = nlohmann::json::parse(d.out);
  for (const auto& m : described["meshes"])
    if (m["name"] == "ring_planet1") train_k = m["mean_stiffness_n_per_m"].get<double>();
  const double iso_k = j["iso6336"]["mesh_stiffness_n_per_m"].get<double>();
  EXPECT_NEAR(iso_k / train_k, 1.0, 1e-9);
  const double energy_k = j["energy"]["mean_n_per_m"].get<double>();
  EXPECT_GT(energy_k, 0.7 * iso_k);
  EXPECT_LT(energy_k, 1.3 * iso_k);
  const double pi = std::numbers::pi, beta = 7.5 * pi / 180;
  const double mt = 10.0 / std::cos(beta), at = std::atan(std::tan(20 * pi / 180) / std::cos(beta));
  const double r1 = 39 * mt / 2, r2 = 99 * mt / 2, rb1 = r1 * std::cos(at), rb2 = r2 * std::cos(at);
  const double ra1 = r1 + 10, ra2 = r2 - 10;
  const double eps = (std::sqrt(ra1 * ra1 - rb1 * rb1) - std::sqrt(ra2 * ra2 - rb2 * rb2) +
                      (r2 - r1) * std::sin(at)) /
                     (pi * mt * std::cos(at));
  EXPECT_NEAR(j["geometry"]["transverse_contact_ratio"].get<double>(), eps, 1e-12);
  // The energy method's pairs in contact: eps_alpha + eps_beta to within its resolution.
  EXPECT_NEAR(j["energy"]["mean_pairs_in_contact"].get<double>(),
              eps + j["geometry"]["overlap_ratio"].get<double>(), 0.02);
  const fs::path out = fresh("internal_stiffness");
  const Outcome f = cli("stiffness " + wt + " --mesh ring_planet1 --out " + out.string());
  ASSERT_EQ(f.code, 0) << f.err;
  EXPECT_NE(f.out.find("an internal pair: its pinion, then its ring"), std::string::npos) << f.out;
  EXPECT_GT(fs::file_size(out / "stiffness.png"), 100U);
  const Outcome g = cli("geometry " + wt + " --mesh ring_planet1");
  EXPECT_EQ(g.code, 2);
  EXPECT_NE(g.err.find("mesh 'ring_planet1': is internal: its geometry is no external gear "
                       "pair's (`geardyn stiffness --mesh ring_planet1` reads its stiffness"),
            std::string::npos)
      << g.err;
}

TEST(Cli, GeometryAndStiffnessReadATrainMeshsGearPair) {
  // The paper's pair (its gear data and torque, Table 1) as a gear pair and as a two-gear train
  // (the wheel's load balancing the pinion's torque): `stiffness --mesh` and `geometry --mesh`
  // of the train print the pair's own numbers, ISO 6336-1's load factor from the mesh's static
  // load.
  const fs::path d = fresh("train_mesh_pair");
  fs::create_directories(d);
  std::ofstream pair_file(d / "pair.toml");
  pair_file << R"([gear]
normal_module_mm = 2.5
helix_angle_deg = 20
center_distance_mm = 150
teeth = [56, 56]
face_width_mm = 20
outside_diameter_mm = [154.98, 154.98]
profile_shift = [0.2075, 0.2075]
[mesh]
mean_stiffness_n_per_m = 2.34e8
[load]
torque_nm = 49.5
)";
  pair_file.close();
  std::string text = "[model]\nform = \"train\"\n[train]\nreference_speed_hz = 30\n";
  for (const char* name : {"pinion", "wheel"})
    text += fmt::format(
        "[[train.body]]\nname = \"{}\"\nteeth = 56\nnormal_module_mm = 2.5\nhelix_angle_deg = 20\n"
        "face_width_mm = 20\nprofile_shift = 0.2075\noutside_diameter_mm = 154.98\n",
        name);
  text +=
      "[[train.torque]]\nbody = \"pinion\"\nmean_nm = 49.5\n[[train.torque]]\nbody = \"wheel\"\n"
      "mean_nm = -49.5\n[[train.mesh]]\nname = \"m\"\ndriving = \"pinion\"\ndriven = \"wheel\"\n"
      "stiffness_source = \"energy\"\ncenter_distance_mm = 150\nmean_stiffness_n_per_m = 2.34e8\n";
  std::ofstream train_file(d / "t.toml");
  train_file << text;
  train_file.close();
  const std::string shipped = case_path("park2010.toml");
  // Every number of the two JSON documents within `rel` of each other, but those `skip` names.
  const std::function<void(const nlohmann::json&, const nlohmann::json&, const std::string&)>
      expect_same = [&](const nlohmann::json& a, const nlohmann::json& b, const std::string& at) {
        ASSERT_EQ(a.type(), b.type()) << at;
        if (a.is_number()) {
          const double x = a.get<double>(), y = b.get<double>();
          EXPECT_LE(std::abs(x - y), 1e-11 * std::max(std::abs(x), std::abs(y))) << at;
        } else if (a.is_object()) {
          for (const auto& [k, v] : a.items())
            if (k.find("inertia") == std::string::npos && k.find("mass") == std::string::npos) {
              ASSERT_TRUE(b.contains(k)) << at << "." << k;
              expect_same(v, b[k], at + "." + k);
            }
        } else if (a.is_array()) {
          ASSERT_EQ(a.size(), b.size()) << at;
          for (std::size_t i = 0; i < a.size(); ++i) expect_same(a[i], b[i], at);
        } else {
          EXPECT_EQ(a, b) << at;
        }
      };
  for (const char* command : {"stiffness", "geometry"}) {
    const Outcome train =
        cli(fmt::format("{} {} --mesh m --json", command, (d / "t.toml").string()));
    const Outcome own = cli(fmt::format("{} {} --json", command, (d / "pair.toml").string()));
    ASSERT_EQ(train.code, 0) << train.err;
    ASSERT_EQ(own.code, 0) << own.err;
    expect_same(nlohmann::json::parse(own.out), nlohmann::json::parse(train.out), command);
  }
  // Run with ISO 6336-1's stiffness, the summary gives the k_m the run took: the one `stiffness`
  // prints for the mesh at its static load.
  const std::string iso = " --set 'train.mesh[0].stiffness_source=\"iso6336\"'";
  const Outcome iso_k = cli("stiffness " + (d / "t.toml").string() + " --mesh m --json" + iso);
  ASSERT_EQ(iso_k.code, 0) << iso_k.err;
  const Outcome iso_run = cli("run " + (d / "t.toml").string() + iso +
                              " --set solver.duration_s=0.001 --out " + (d / "iso").string());
  ASSERT_EQ(iso_run.code, 0) << iso_run.err;
  const double k_iso =
      nlohmann::json::parse(iso_k.out)["iso6336"]["mesh_stiffness_n_per_m"].get<double>();
  EXPECT_NEAR(nlohmann::json::parse(
                  slurp(d / "iso" / "summary.json"))["meshes"][0]["mean_stiffness_n_per_m"]
                  .get<double>(),
              k_iso, 1e-10 * k_iso);
  // The shipped reducer's second stage, its files written; a mesh it has not, a name given to a
  // pair and an internal mesh are refused.
  const std::string reducer = case_path("two_stage_reducer.toml");
  const Outcome stage2 =
      cli("stiffness " + reducer + " --mesh stage2 --out " + (d / "stage2").string());
  ASSERT_EQ(stage2.code, 0) << stage2.err;
  EXPECT_NE(stage2.out.find("mesh stiffness of two_stage_reducer, mesh 'stage2'"),
            std::string::npos)
      << stage2.out;
  EXPECT_TRUE(fs::exists(d / "stage2" / "stiffness.csv"));
  expect_refused(cli("geometry " + reducer + " --mesh stage3"),
                 "--mesh = \"stage3\": the train has no mesh of that name; its meshes are stage1, "
                 "stage2");
  expect_refused(cli("geometry " + shipped + " --mesh m"),
                 "--mesh = \"m\": names a gear train's mesh");
  const std::string planetary = case_path("lin_parker_1999.toml");
  const Outcome ring = cli("geometry " + planetary + " --mesh planet_ring2");
  EXPECT_EQ(ring.code, 2) << ring.err;
  EXPECT_NE(ring.err.find("mesh 'planet_ring2': is internal: its geometry is no external gear "
                          "pair's"),
            std::string::npos)
      << ring.err;
}

TEST(Cli, ATrainsModesAndTheFormsThePapersStudyRefuses) {
  const std::string reducer = case_path("two_stage_reducer.toml");
  const Outcome m = cli("modes " + reducer + " --json");
  ASSERT_EQ(m.code, 0) << m.err;
  const nlohmann::json j = nlohmann::json::parse(m.out);
  ASSERT_EQ(j["modes"].size(), 6U);                              // six bodies, none held
  EXPECT_LT(j["modes"][0]["frequency_hz"].get<double>(), 1e-6);  // the free rotation
  EXPECT_TRUE(j["modes"][5]["mesh_energy"].contains("stage1"));
  // The elements' keys are listed with the sections' (the docs' tables: KeyTablesInTheDocs...).
  const nlohmann::json keys = nlohmann::json::parse(cli("keys --json").out);
  const auto backlash = std::find_if(keys.begin(), keys.end(), [](const nlohmann::json& k) {
    return k["key"] == "train.mesh[].backlash_um";
  });
  ASSERT_NE(backlash, keys.end());
  EXPECT_EQ((*backlash)["default"], "100");
  EXPECT_NE(cli("keys").out.find("train.speed[].acceleration_harmonics (rad/s^2)"),
            std::string::npos);
  const fs::path d = fresh("train_refused");
  const std::string out = " --out " + d.string();
  // `reproduce park2010` is the paper's study of its dimensional pair: every other form is
  // refused before a case runs, its form and where it was set named, nothing written (the
  // non-dimensional form ran all 11 cases alike, its panels' keys unread).
  const std::string cases_dir = case_path("");
  for (const auto& [file, form, why] :
       {std::tuple{reducer, "train", "spreads them over its elements"},
        std::tuple{cases_dir + "kahraman_singh.toml", "nondimensional", "reads none of them"},
        std::tuple{cases_dir + "park2010_coupled.toml", "coupled", "another model"}}) {
    const Outcome o = cli("reproduce park2010 --case " + file + out);
    EXPECT_EQ(o.code, 2) << file << "\n" << o.err;
    for (const std::string said : {fmt::format("model.form = \"{}\"", form), std::string(why),
                                   std::string("gear_pair"), std::string("model.form from ")})
      EXPECT_NE(o.err.find(said), std::string::npos) << said << "\n" << o.err;
    EXPECT_EQ(o.out.find("cases"), std::string::npos) << o.out;  // refused before it began
    EXPECT_FALSE(fs::exists(d)) << file;
  }
  // A train that turns freely whose mean torques do not balance has no orbit to continue:
  // said, nothing written.
  const Outcome free =
      cli("continue " + reducer +
          " --set train.torque[1].balances=false --set train.torque[1].mean_nm=-1000 "
          "--param train.reference_speed_hz "
          "--from 50 --to 60" +
          out);
  expect_refused(free, "turns freely and has no periodic orbit");
  EXPECT_FALSE(fs::exists(d));
  // A mesh to a body that is not there: its name, key and line, exit 2, nothing written.
  fs::create_directories(d);
  std::ofstream(d / "bad.toml") << "[model]\nform = \"train\"\n[train]\nreference_speed_hz = 50\n"
                                   "[[train.body]]\nname = \"a\"\ninertia_kg_m2 = 1\n"
                                   "[[train.mesh]]\ndriving = \"a\"\ndriven = \"b\"\n"
                                   "mean_stiffness_n_per_m = 1e8\n";
  const Outcome bad = cli("run " + (d / "bad.toml").string() + " --out " + (d / "out").string());
  expect_refused(bad, "bad.toml:10:10: train: mesh 'mesh1': driven = \"b\": no body of that name");
  EXPECT_FALSE(fs::exists(d / "out"));
  fs::remove_all(d);
}

TEST(Cli, ATrainsSweepReadsEveryMeshAndNamesTheOneItReads) {
  // The loose gear swept in its input's acceleration amplitude (an entry of its harmonics)
  // across the rattle onset (about 241 rad/s^2): the terminal names the meshes and the one
  // read, sweep.csv has its columns, the figure of every mesh is drawn; a mesh that is not
  // there is refused before any work, exit 2, nothing written.
  const std::string loose = case_path("loose_gear_rattle.toml");
  const std::string args = "sweep " + loose +
                           " --param 'train.speed[0].acceleration_harmonics[0][0]' --from 200 "
                           "--to 300 --points 3 --direction up";
  const fs::path d = fresh("train_sweep");
  const Outcome o = cli(args + " --out " + d.string());
  ASSERT_EQ(o.code, 0) << o.err;
  EXPECT_NE(o.out.find("each of the train's meshes read (rattle); the statistics and jumps "
                       "below: mesh rattle"),
            std::string::npos)
      << o.out;
  const std::string csv = slurp(d / "sweep.csv");
  EXPECT_NE(csv.find("rattle_impacts_per_period"), std::string::npos);
  EXPECT_NE(csv.find(",none,\n"), std::string::npos) << csv;       // 200: in contact
  EXPECT_NE(csv.find(",sustained,\n"), std::string::npos) << csv;  // 300: rattles
  // The figure draws the mesh's own column of sweep.csv.
  const std::string header = csv.substr(0, csv.find('\n'));
  const std::string before = header.substr(0, header.find("rattle_pp_delta_bar"));
  const auto column = std::count(before.begin(), before.end(), ',') + 1;
  EXPECT_NE(slurp(d / "mesh_responses_body.gp").find(fmt::format("? ${} : NaN", column)),
            std::string::npos);
  EXPECT_GT(fs::file_size(d / "mesh_responses.png"), 100u);
  const nlohmann::json j = nlohmann::json::parse(slurp(d / "summary.json"));
  EXPECT_EQ(j["meshes"], nlohmann::json::array({"rattle"}));
  const fs::path e = fresh("train_sweep_bad");
  const Outcome bad = cli(args + " --mesh gear --out " + e.string());
  expect_refused(bad,
                 "--mesh = \"gear\": the train has no mesh of that name; its meshes are "
                 "rattle");
  EXPECT_FALSE(fs::exists(e));
  fs::remove_all(d);
}

TEST(Cli, ALooseGearsOrbitFromTheCommandLine) {
  // `geardyn orbit` of a train with a prescribed speed: its JSON as every orbit's, with the
  // meshes' impacts per period; a train that turns freely is taken modulo its rotation.
  const std::string loose = case_path("loose_gear_rattle.toml");
  const Outcome o = cli("orbit " + loose +
                        " --set 'train.speed[0].acceleration_harmonics=[[290, 2, 0]]' "
                        "--segments 4 --settle-periods 200 --json");
  ASSERT_EQ(o.code, 0) << o.err;
  const nlohmann::json j = nlohmann::json::parse(o.out);
  EXPECT_EQ(j["model"], "train");
  EXPECT_TRUE(j["converged"].get<bool>());
  EXPECT_EQ(j["coordinates"], (nlohmann::json{"loose_rad", "loose_rad_s"}));
  EXPECT_GE(j["meshes"][0]["impacts_per_period"].get<int>(), 2);
  EXPECT_FALSE(j["stable"].get<bool>());
  const Outcome text = cli("orbit " + loose +
                           " --set 'train.speed[0].acceleration_harmonics=[[290, 2, 0]]' "
                           "--segments 4 --settle-periods 200");
  EXPECT_NE(text.out.find("mesh rattle"), std::string::npos) << text.out;
  // Its unknowns, given back as --state, start a Newton that has nothing left to do (no
  // settling), and land on the same section state; a --state of another size is named.
  const Outcome from = cli("orbit " + loose +
                           " --set 'train.speed[0].acceleration_harmonics=[[290, 2, 0]]' "
                           "--segments 4 --settle-periods 0 --json" +
                           state_option(j["unknowns"]));
  ASSERT_EQ(from.code, 0) << from.err;
  const nlohmann::json again = nlohmann::json::parse(from.out);
  EXPECT_LE(again["iterations"].get<int>(), 1);
  ASSERT_EQ(again["state"].size(), j["state"].size());
  for (std::size_t k = 0; k < j["state"].size(); ++k)
    EXPECT_NEAR(again["state"][k].get<double>(), j["state"][k].get<double>(),
                1e-9 * std::abs(j["state"][k].get<double>()) + 1e-15)
        << k;
  const Outcome bad = cli("orbit " + loose + " --state 0 0 0");
  EXPECT_EQ(bad.code, 2);
  EXPECT_NE(bad.err.find("--state: 3 values given; this train takes 2 (its free coordinates, "
                         "then their rates, SI: loose_rad, loose_rad_s"),
            std::string::npos)
      << bad.err;
  EXPECT_EQ(bad.out, "");
  // As many values as the train takes, however many (a planetary set's 34), and one at least:
  // the count is the case's to check.
  std::string thirty;
  for (int k = 0; k < 30; ++k) thirty += " 0";
  const Outcome many = cli("orbit " + case_path("planetary_set.toml") + " --state" + thirty);
  EXPECT_EQ(many.code, 2);
  EXPECT_NE(many.err.find("--state: 30 values given; this train takes 34"), std::string::npos)
      << many.err;
  const Outcome one = cli("orbit " + loose + " --state 0");
  EXPECT_EQ(one.code, 2);
  EXPECT_NE(one.err.find("--state: 1 value given; this train takes 2"), std::string::npos)
      << one.err;
  const Outcome free = cli("orbit " + case_path("idler_train.toml") + " --json");
  ASSERT_EQ(free.code, 0) << free.err;
  const nlohmann::json f = nlohmann::json::parse(free.out);
  EXPECT_TRUE(f["modulo_rotation"].get<bool>());
  EXPECT_EQ(f["coordinates"],
            (nlohmann::json{"idler_rad", "driven_rad", "idler_rad_s", "driven_rad_s"}));
  EXPECT_TRUE(f["stable"].get<bool>());
}

TEST(Cli, ATrainsStabilityChartFromTheCommandLine) {
  // `geardyn stability` of a train over an element's key (stability_test checks the numbers):
  // its table and figure beside a file of the user's, and a key of no element refused with
  // exit 2 before anything is written.
  const std::string idler = case_path("idler_train.toml");
  const fs::path d = fresh("train_stability");
  fs::create_directories(d);
  std::ofstream(d / "notes.txt") << "mine";
  const Outcome o = cli("stability " + idler +
                        " --param 'train.mesh[1].damping_ratio' --from 0.01 --to 0.1 --points 3"
                        " --out " +
                        d.string());
  ASSERT_EQ(o.code, 0) << o.err;
  EXPECT_NE(o.out.find("3 samples, 0 unstable"), std::string::npos) << o.out;
  std::ifstream csv(d / "stability.csv");
  std::string line;
  int rows = 0;
  while (std::getline(csv, line)) ++rows;
  EXPECT_EQ(rows, 4);  // the header and 3 samples
  EXPECT_TRUE(fs::exists(d / "stability.svg"));
  std::ifstream mine(d / "notes.txt");
  std::getline(mine, line);
  EXPECT_EQ(line, "mine");
  const fs::path none = fresh("train_stability_refused");
  const Outcome bad =
      cli("stability " + idler +
          " --param 'train.mesh[1].name' --from 0.01 --to 0.1 --points 3 --out " + none.string());
  expect_refused(bad, "train.mesh[1].name: not a real number");
  EXPECT_FALSE(fs::exists(none));
  fs::remove_all(d);
}

TEST(Cli, TheShippedPlanetarySetIsLinAndParkersForThreeFourAndFivePlanets) {
  // cases/lin_parker_1999.toml's modes: three planets as written, four and five by one key,
  // each with Table 2's planet modes (validation.cpp's planetary_lin_parker compares every
  // frequency); the planets written once are copied, each mesh and pin named by its copy.
  const std::string set = case_path("lin_parker_1999.toml");
  for (const int planets : {3, 4, 5}) {
    SCOPED_TRACE(planets);
    const Outcome o = cli(fmt::format("modes {} --json --set train.planets={}", set, planets));
    ASSERT_EQ(o.code, 0) << o.err;
    const nlohmann::json modes = nlohmann::json::parse(o.out)["modes"];
    ASSERT_EQ(modes.size(), static_cast<std::size_t>(3 * (3 + planets)));
    int planet_modes = 0;
    for (const auto& m : modes) {
      planet_modes += m["type"] == "planet";
      if (m["type"] == "planet") EXPECT_EQ(m["multiplicity"], planets - 3);
    }
    EXPECT_EQ(planet_modes, 3 * (planets - 3));
    EXPECT_TRUE(modes[0]["mesh_energy"].contains(fmt::format("sun_planet{}", planets)));
    EXPECT_TRUE(modes[0]["bearing_energy"].contains(fmt::format("pin{}", planets)));
    // The lowest translational pair: 743.2, 727.0 and 710.0 Hz in the table.
    const double table = planets == 3 ? 743.2 : planets == 4 ? 727.0 : 710.0;
    EXPECT_NEAR(modes[1]["frequency_hz"].get<double>(), table, 5e-4 * table);
    EXPECT_EQ(modes[1]["type"], "translational");
  }
  // With the phase from the layout, 85 + 305 teeth allow 3 and 5 equally spaced planets, not 4:
  // refused naming a copied mesh and the line of its template, exit 2.
  const Outcome five = cli("modes " + set + " --set train.mesh_phase=layout --set train.planets=5");
  EXPECT_EQ(five.code, 0) << five.err;
  const Outcome four = cli("modes " + set + " --set train.mesh_phase=layout --set train.planets=4");
  expect_refused(four, "lin_parker_1999.toml:");
  EXPECT_NE(four.err.find("teeth cannot interlock"), std::string::npos) << four.err;
  // A count of planets with no angle for one of them is refused naming the key.
  const Outcome angles = cli("modes " + set + " --set 'train.planet_angles_deg=[0, 120]'");
  expect_refused(angles, "planet_angles_deg has 2 angles for planets = 3");
}

TEST(Cli, TheShippedPlanetaryStageRattlesAtLightLoadAndSharesItsLoad) {
  // cases/planetary_set.toml at the light load and transmission error its comment gives: the
  // planets rattle (their meshes separate in the steady part); its summary's load sharing, and
  // a file of the user's kept beside ours.
  const std::string set = case_path("planetary_set.toml");
  const fs::path d = fresh("planetary");
  fs::create_directories(d);
  std::ofstream(d / "notes.txt") << "mine";
  const Outcome o =
      cli("run " + set +
          " --set solver.duration_s=0.05 --set solver.output_interval_s=5e-5 --set "
          "'train.torque[0].mean_nm=5' --set "
          "'train.torque[1].mean_nm=-21.25' --set 'train.mesh[0].transmission_error_um=[[8, 0]]' "
          "--set 'train.mesh[1].transmission_error_um=[[8, 0]]' --plot --out " +
          d.string());
  ASSERT_EQ(o.code, 0) << o.err;
  const nlohmann::json j = nlohmann::json::parse(slurp(d / "summary.json"));
  for (const auto& m : j["meshes"]) EXPECT_EQ(m["regime"], "sustained") << m["name"];
  ASSERT_EQ(j["load_sharing"].size(), 2U);
  EXPECT_EQ(j["load_sharing"][0]["gear"], "sun");
  EXPECT_EQ(j["load_sharing"][0]["lost_contact"].size(), 3U);
  EXPECT_NE(o.out.find("load sharing sun  over 3 meshes"), std::string::npos) << o.out;
  // The per-planet figure: a row per group, a line per planet's mesh, and the factor, each
  // sample's factor the group's n max F / sum F (undefined where the planets carry nothing).
  const std::string body = slurp(d / "load_sharing_body.gp");
  EXPECT_NE(body.find("layout 2,1"), std::string::npos) << body;
  EXPECT_NE(body.find("using 1:4 skip 1 axes x1y1 with lines lw 1.2 lc rgb '#2e8b57' title "
                      "'sun_planet3'"),
            std::string::npos)
      << body;
  EXPECT_NE(body.find("using 1:9 skip 1 axes x1y2"), std::string::npos) << body;
  EXPECT_NE(body.find("lost contact: sun_planet1 sun_planet2 sun_planet3"), std::string::npos)
      << body;
  EXPECT_TRUE(fs::exists(d / "load_sharing.png"));
  const CsvTable csv = read_csv(d / "load_sharing_plot.csv");
  EXPECT_EQ(csv.header,
            "t_ms,sun_planet1_force_n,sun_planet2_force_n,sun_planet3_force_n,"
            "planet_ring1_force_n,planet_ring2_force_n,planet_ring3_force_n,sun_factor,"
            "ring_factor");
  int rows = 0;
  for (const std::vector<std::string>& cells : csv.rows) {
    std::vector<double> v;
    for (const std::string& f : cells) v.push_back(std::stod(f));
    ASSERT_EQ(v.size(), 9U);
    const double sum = v[1] + v[2] + v[3];
    if (sum > 0) {
      EXPECT_NEAR(v[7], 3 * std::max({v[1], v[2], v[3]}) / sum, 1e-6 * v[7]) << cells[0];
      ++rows;
    } else {
      EXPECT_TRUE(std::isnan(v[7])) << cells[0];
    }
  }
  EXPECT_GT(rows, 100);
  EXPECT_EQ(slurp(d / "notes.txt"), "mine");
  fs::remove_all(d);
}

TEST(Cli, APlanetarySweepReadsItsLoadSharingPerPoint) {
  // The shipped stage with one pin 20 um off, swept in speed: the terminal gives each group's
  // factor over the points, sweep.csv two columns per group, summary.json the groups, and the
  // mesh figure a panel of the factor drawn from its columns.
  const std::string set = case_path("planetary_set.toml");
  const fs::path d = fresh("planetary_sweep");
  const Outcome o = cli("sweep " + set +
                        " --param train.reference_speed_hz --from 10 --to 20 --points 2 "
                        "--direction up --measure-periods 2 --set "
                        "'train.planet_pin_errors_um=[[0, 20], [0, 0], [0, 0]]' --out " +
                        d.string());
  ASSERT_EQ(o.code, 0) << o.err;
  EXPECT_NE(o.out.find("load-sharing factor of sun's meshes from 1.087"), std::string::npos)
      << o.out;
  EXPECT_NE(o.out.find("load-sharing factor of ring's meshes from"), std::string::npos) << o.out;
  const nlohmann::json j = nlohmann::json::parse(slurp(d / "summary.json"));
  ASSERT_EQ(j["load_sharing"].size(), 2U) << j;
  EXPECT_EQ(j["load_sharing"][0]["label"], "sun");
  EXPECT_EQ(j["load_sharing"][1]["meshes"],
            nlohmann::json::array({"planet_ring1", "planet_ring2", "planet_ring3"}));
  const std::string csv = slurp(d / "sweep.csv");
  const std::string header = csv.substr(0, csv.find('\n'));
  const std::string before = header.substr(0, header.find("sun_load_sharing_factor"));
  ASSERT_NE(before, header);
  const auto column = std::count(before.begin(), before.end(), ',') + 1;
  const std::string body = slurp(d / "mesh_responses_body.gp");
  EXPECT_NE(body.find("set ylabel 'load-sharing factor'"), std::string::npos) << body;
  EXPECT_NE(body.find(fmt::format("? ${} : NaN) with linespoints dt 1 pt 7 ps 0.4 lc rgb "
                                  "'#1f3b73' title 'up: sun'",
                                  column)),
            std::string::npos)
      << body;
  // The planets' pins, the copies of the written "pin", are one legend entry a direction.
  const std::string parts = slurp(d / "part_forces_body.gp");
  EXPECT_NE(parts.find("title 'up: pin1-3_force_x_n'"), std::string::npos) << parts;
  EXPECT_EQ(parts.find("title 'up: pin2_force_x_n'"), std::string::npos) << parts;
  EXPECT_NE(parts.find("title 'up: sun_bearing_force_x_n'"), std::string::npos) << parts;
  // A planet's pin error is swept by its entry, [i][0] radial or [i][1] tangential; another
  // entry is refused before any work.
  const Outcome bad = cli("sweep " + set +
                          " --param 'train.planet_pin_errors_um[0][2]' --from 0 --to 20 --points 2 "
                          "--out " +
                          (d / "bad").string());
  expect_refused(bad,
                 "--param train.planet_pin_errors_um[0][2]: unknown key (a planet's pin "
                 "error is train.planet_pin_errors_um[i][0] radial or [i][1] tangential)");
  EXPECT_FALSE(fs::exists(d / "bad"));
  fs::remove_all(d);
}

TEST(Cli, APlanetarySetInItsTurningFrameWhirlsAndDrawsItsModesAgainstSpeed) {
  // Lin and Parker's set with the frame's rotation terms: modes.json gives each mode's
  // imaginary part, the first translational pair split; the Campbell diagram reads the modes at
  // 49 speeds from 0 (at 0, the modes at rest: the pair one frequency) and draws each as a
  // curve.
  const std::string lp = case_path("lin_parker_1999.toml");
  const fs::path d = fresh("frame_terms");
  const Outcome o =
      cli("modes " + lp +
          " --set train.frame_terms=true --set train.reference_speed_hz=100 --out " + d.string());
  ASSERT_EQ(o.code, 0) << o.err;
  const nlohmann::json j = nlohmann::json::parse(slurp(d / "modes.json"));
  ASSERT_TRUE(j["modes"][1].contains("shape_imag")) << j["modes"][1];
  const double f1 = j["modes"][1]["frequency_hz"], f2 = j["modes"][2]["frequency_hz"];
  EXPECT_GT(f2 - f1, 10.0);  // 743.2 Hz at rest, split by the frame's 27.8 Hz
  EXPECT_EQ(j["modes"][1]["multiplicity"], 1);
  std::istringstream table(slurp(d / "campbell_modes.csv"));
  std::string line;
  std::getline(table, line);
  EXPECT_EQ(line.substr(0, 28), "speed_hz,mode1_hz,mode2_hz,m");
  std::getline(table, line);
  std::vector<double> rest;
  std::istringstream fields(line);
  for (std::string f; std::getline(fields, f, ',');) rest.push_back(std::stod(f));
  ASSERT_GE(rest.size(), 4U);
  EXPECT_EQ(rest[0], 0.0);
  EXPECT_NEAR(rest[2] / 743.2, 1.0, 5e-4);
  EXPECT_NEAR(rest[3] / rest[2], 1.0, 1e-9);
  int rows = 1;
  while (std::getline(table, line)) ++rows;
  EXPECT_EQ(rows, 49);
  EXPECT_NE(slurp(d / "campbell_body.gp").find("$modes every ::1 using 1:3 with lines"),
            std::string::npos);
  fs::remove_all(d);
}

TEST(Cli, ASpatialWheelCarriesItsHelixsThrustAndMomentOnItsBearing) {
  // The shipped reducer's first wheel made spatial on a bearing with axial and tilt
  // stiffness: at rest its bearing carries the mesh's static force split by the base helix
  // angle, cos(beta_b) F radially and sin(beta_b) F axially, and the axial force's moment about
  // the wheel's centre at its base radius, R_b sin(beta_b) F (the paper's geometry: 61 teeth,
  // m_n 1.75 mm, beta 25 deg, alpha_n 20 deg); the run reads them over time, timeseries.csv
  // and modes.json name the new coordinates.
  const std::string set = case_path("two_stage_reducer.toml");
  const std::string spatial =
      " --set 'train.body[2].dof=\"spatial\"' --set 'train.bearing=[{name=\"wheel1_bearing\", "
      "body=\"wheel1\", stiffness_n_per_m=5e8, axial_stiffness_n_per_m=2e8, "
      "tilt_stiffness_n_m_per_rad=1e6}]'";
  const fs::path d = fresh("spatial");
  const Outcome o =
      cli("run " + set + " --set solver.duration_s=0.01" + spatial + " --out " + d.string());
  ASSERT_EQ(o.code, 0) << o.err;
  EXPECT_NE(o.out.find("axial "), std::string::npos) << o.out;
  const nlohmann::json j = nlohmann::json::parse(slurp(d / "summary.json"));
  const double f = j["meshes"][0]["static_force_n"];
  const nlohmann::json& b = j["bearings"][0];
  constexpr double kDeg = std::numbers::pi / 180;
  const double alpha_t = std::atan(std::tan(20 * kDeg) / std::cos(25 * kDeg));
  const double beta_b = std::atan(std::tan(25 * kDeg) * std::cos(alpha_t));
  const double r_b = 0.5 * 61 * 1.75e-3 / std::cos(25 * kDeg) * std::cos(alpha_t);
  EXPECT_NEAR(std::hypot(b["static_force_x_n"].get<double>(), b["static_force_y_n"].get<double>()) /
                  (std::cos(beta_b) * f),
              1.0, 1e-9);
  EXPECT_NEAR(b["static_axial_force_n"].get<double>() / (std::sin(beta_b) * f), 1.0, 1e-9);
  EXPECT_NEAR(
      std::hypot(b["static_moment_x_nm"].get<double>(), b["static_moment_y_nm"].get<double>()) /
          (r_b * std::sin(beta_b) * f),
      1.0, 1e-9);
  // Over the run the mesh force varies, and the axial force with it, about its static value.
  const double low = b["min_axial_force_n"], high = b["max_axial_force_n"];
  EXPECT_LT(low, b["static_axial_force_n"].get<double>());
  EXPECT_GT(high, b["static_axial_force_n"].get<double>());
  std::istringstream csv(slurp(d / "timeseries.csv"));
  std::string header;
  std::getline(csv, header);
  for (const char* column : {",wheel1_z_m,wheel1_tx_rad,wheel1_ty_rad,",
                             ",wheel1_bearing_axial_force_n,wheel1_bearing_moment_x_nm,"
                             "wheel1_bearing_moment_y_nm"})
    EXPECT_NE(header.find(column), std::string::npos) << header;
  fs::remove_all(d);
  const Outcome m = cli("modes " + set + spatial + " --out " + d.string());
  ASSERT_EQ(m.code, 0) << m.err;
  const nlohmann::json shape = nlohmann::json::parse(slurp(d / "modes.json"))["modes"][0]["shape"];
  for (const char* q : {"wheel1_x", "wheel1_z", "wheel1_tx", "wheel1_ty"})
    EXPECT_TRUE(shape.contains(q)) << shape;
  fs::remove_all(d);
}

TEST(Cli, TrainFormPrintsACoupledCaseAsATrainThatRunsAsIt) {
  // `geardyn train-form` prints the shipped coupled case as a train of elements; written to a
  // file and run, its mesh reads as the coupled case's run (which builds the same train in
  // memory: the printed numbers lose nothing that shows; impacts, dynamic factor to 1e-6). A form
  // the train does not model is refused naming its key, exit 2, nothing printed.
  const std::string coupled = case_path("park2010_coupled.toml");
  const std::string shorter = " --set solver.duration_s=0.02";
  const Outcome form = cli("train-form " + coupled + shorter);
  ASSERT_EQ(form.code, 0) << form.err;
  for (const char* text : {"form = \"train\"", "dof = \"spatial\"", "name = \"wheel_bearing\"",
                           "tilt_stiffness_n_m_per_rad = 280000"})
    EXPECT_NE(form.out.find(text), std::string::npos) << text;
  const fs::path d = fresh("train_form");
  fs::create_directories(d);
  { std::ofstream(d / "train.toml") << form.out; }
  const Outcome one = cli("run " + coupled + shorter + " --out " + (d / "coupled").string());
  const Outcome train =
      cli("run " + (d / "train.toml").string() + " --out " + (d / "train").string());
  ASSERT_EQ(one.code, 0) << one.err;
  ASSERT_EQ(train.code, 0) << train.err;
  const nlohmann::json a =
      nlohmann::json::parse(slurp(d / "coupled" / "summary.json"))["meshes"][0];
  const nlohmann::json b = nlohmann::json::parse(slurp(d / "train" / "summary.json"))["meshes"][0];
  EXPECT_GT(a["impacts"].get<int>(), 3);
  EXPECT_EQ(b["impacts"], a["impacts"]) << a;
  EXPECT_NEAR(b["dynamic_factor_with_startup"].get<double>() /
                  a["dynamic_factor_with_startup"].get<double>(),
              1.0, 1e-6);
  fs::remove_all(d);
  const Outcome bad = cli("train-form " + coupled + " --set model.dof=5");
  expect_refused(bad, "--set model.dof=5: model.dof = 5: must be 3, 6 or 12");
  EXPECT_EQ(bad.out, "");
  // A train that cannot be built is refused as a run refuses it, never printed back.
  const std::string reducer = case_path("two_stage_reducer.toml");
  const Outcome nobody = cli("train-form " + reducer + " --set 'train.mesh[1].driven=\"wheel\"'");
  expect_refused(nobody, "mesh 'stage2': driven = \"wheel\": no body of that name");
  EXPECT_EQ(nobody.out, "");
}

TEST(Cli, ASunStrikesItsBearingsClearanceUnderItsRunout) {
  // The shipped stage's floating sun in a bearing with 5 um of radial clearance and 5 um of
  // runout: its centre strikes the clearance's edges, in x and in y; summary.json counts each
  // direction's impacts and time inside, the terminal says it; a negative clearance is refused
  // naming its key, exit 2, nothing written.
  const std::string set = case_path("planetary_set.toml");
  const fs::path d = fresh("clearance");
  const std::string args = "run " + set +
                           " --set solver.duration_s=0.02 --set train.body[0].eccentricity_um=5 "
                           "--set 'train.bearing[0].clearance_um=";
  const Outcome o = cli(args + "5' --out " + d.string());
  ASSERT_EQ(o.code, 0) << o.err;
  EXPECT_NE(o.out.find("clearance: x "), std::string::npos) << o.out;
  const nlohmann::json j = nlohmann::json::parse(slurp(d / "summary.json"))["bearings"];
  ASSERT_TRUE(j[0].contains("clearance_x")) << j[0];
  EXPECT_GT(j[0]["clearance_x"]["impacts"].get<int>(), 0);
  const double inside = j[0]["clearance_y"]["inside_fraction"];
  EXPECT_TRUE(inside > 0 && inside < 1) << inside;
  EXPECT_FALSE(j[1].contains("clearance_x"));  // the ring's bearing has none
  fs::remove_all(d);
  // Swept in the runout: each clearance direction's columns; centred (no runout) the sun stays
  // inside, struck by its runout it hits an edge a whole number of times a period, and leaves
  // the clearance's inside for part of it.
  const Outcome sweep = cli("sweep " + set +
                            " --param 'train.body[0].eccentricity_um' --from 0 --to 10 --points 2 "
                            "--direction up --measure-periods 2 --set "
                            "'train.bearing[0].clearance_um=5' --out " +
                            d.string());
  ASSERT_EQ(sweep.code, 0) << sweep.err;
  const CsvTable csv = read_csv(d / "sweep.csv");
  const std::size_t impacts = csv.column("sun_bearing_x_impacts_per_period"),
                    inside_x = csv.column("sun_bearing_x_inside_fraction");
  ASSERT_LT(inside_x, csv.names.size()) << csv.header;
  ASSERT_LT(impacts, csv.names.size()) << csv.header;
  EXPECT_LT(csv.column("sun_bearing_y_impacts_per_period"), csv.names.size());
  const std::vector<std::vector<std::string>>& rows = csv.rows;
  ASSERT_EQ(rows.size(), 2U);
  EXPECT_EQ(std::stod(rows[0][impacts]), 0.0);
  EXPECT_EQ(std::stod(rows[0][inside_x]), 1.0);
  const double struck = std::stod(rows[1][impacts]);
  EXPECT_GT(struck, 0);
  EXPECT_EQ(struck, std::round(struck));
  EXPECT_LT(std::stod(rows[1][inside_x]), 1.0);
  EXPECT_EQ(nlohmann::json::parse(slurp(d / "summary.json"))["clearances"],
            nlohmann::json::array({"sun_bearing_x", "sun_bearing_y"}));
  fs::remove_all(d);
  const Outcome bad = cli(args + "-1' --out " + d.string());
  expect_refused(bad, "train.bearing[0].clearance_um = -1");
  EXPECT_FALSE(fs::exists(d));
}

TEST(Cli, TheLooseGearRattles) {
  // The shipped loose-gear case is above its onset of rattle: the loose gear leaves its flank
  // and strikes again in every period of the engine's firing order.
  const fs::path d = fresh("rattle");
  const Outcome o = cli("run " + case_path("loose_gear_rattle.toml") + " --out " + d.string());
  ASSERT_EQ(o.code, 0) << o.err;
  const nlohmann::json j = nlohmann::json::parse(slurp(d / "summary.json"))["meshes"][0];
  EXPECT_EQ(j["regime"], "sustained");
  // 0.4 s at 25 Hz: ten periods; at least one impact in each.
  EXPECT_GE(j["impacts"].get<int>(), 10) << j;
  // events.csv holds each of them, and each separation, by the mesh's name.
  std::istringstream events(slurp(d / "events.csv"));
  std::string row;
  std::getline(events, row);
  EXPECT_EQ(row, "t_s,part,kind,velocity_m_s");
  std::int64_t impacts = 0, separations = 0;
  while (std::getline(events, row)) {
    impacts += row.find(",rattle,impact,") != std::string::npos ||
               row.find(",rattle,backside_impact,") != std::string::npos;
    separations += row.find(",rattle,separation,") != std::string::npos;
  }
  EXPECT_EQ(impacts, j["impacts"].get<std::int64_t>());
  EXPECT_EQ(separations, j["separations"].get<std::int64_t>());
  fs::remove_all(d);
}

TEST(Cli, AClutchDamperRunsInEveryStudyAsAnyElement) {
  // The shipped loose gear behind a clutch damper: every command takes the damper as it takes a
  // shaft, and reads its torque, twist, contact history and strain energy by its name.
  const std::string c = case_path("loose_gear_damper.toml");
  const fs::path d = fresh("damper");
  const Outcome run = cli("run " + c + " --out " + (d / "run").string());
  ASSERT_EQ(run.code, 0) << run.err;
  const nlohmann::json s = nlohmann::json::parse(slurp(d / "run" / "summary.json"));
  ASSERT_EQ(s["joints"].size(), 1U);
  const nlohmann::json& clutch = s["joints"][0];
  EXPECT_EQ(clutch["name"], "clutch");
  // The drag's 0.15 N m reflected onto the input at rest, carried by the idle spring.
  EXPECT_NEAR(clutch["static_torque_nm"].get<double>(), 0.2 * 30 / 40, 1e-9);
  EXPECT_NEAR(clutch["static_twist_rad"].get<double>(), 0.15 / 8, 1e-9);
  EXPECT_GT(clutch["max_torque_nm"].get<double>(), clutch["min_torque_nm"].get<double>());
  EXPECT_TRUE(clutch["contact"].contains("inside_fraction"));
  // The damper isolates the loose gear: no rattle once settled.
  EXPECT_EQ(s["meshes"][0]["steady"]["impacts"], 0) << s["meshes"][0];
  EXPECT_NE(slurp(d / "run" / "timeseries.csv").find(",clutch_torque_nm,clutch_twist_rad"),
            std::string::npos);
  const Outcome modes = cli("modes " + c + " --out " + (d / "modes").string());
  ASSERT_EQ(modes.code, 0) << modes.err;
  EXPECT_NE(modes.out.find("clutch"), std::string::npos) << modes.out;
  const nlohmann::json m = nlohmann::json::parse(slurp(d / "modes" / "modes.json"));
  // The engine's speed is prescribed: its first mode is the input's on the idle spring.
  EXPECT_GT(m["modes"][0]["joint_energy"]["clutch"].get<double>(), 0.99) << m["modes"][0];
  // The Campbell diagram draws the firing order (order 2 of the engine, the reference) and
  // where it meets each mode: at half the mode's frequency; logarithmic in frequency, so that
  // the clutch's mode at some 7 Hz shows beside the mesh's at some 4 kHz.
  std::istringstream orders(slurp(d / "modes" / "campbell_orders.csv"));
  std::string line;
  std::getline(orders, line);
  EXPECT_EQ(line, "mode,frequency_hz,excitation,resonance_speed_hz");
  for (const nlohmann::json& mode : m["modes"]) {
    ASSERT_TRUE(std::getline(orders, line));
    const std::string name = "\"speed 'firing' order 2\",";
    ASSERT_NE(line.find(name), std::string::npos) << line;
    const double at = std::stod(line.substr(line.find(name) + name.size()));
    EXPECT_NEAR(at, mode["frequency_hz"].get<double>() / 2, 1e-9 * at) << line;
  }
  EXPECT_FALSE(std::getline(orders, line)) << line;
  const std::string gp = slurp(d / "modes" / "campbell_body.gp");
  EXPECT_NE(gp.find("title 'speed ''firing'' order 2'"), std::string::npos) << gp;
  EXPECT_NE(gp.find("set logscale y"), std::string::npos) << gp;
  EXPECT_NE(gp.find("$order_crossings"), std::string::npos) << gp;
  // A train without harmonics of its torques or speeds has no excitation order, and keeps a linear
  // axis.
  ASSERT_EQ(cli("modes " + case_path("two_stage_reducer.toml") + " --out " +
                (d / "reducer_modes").string())
                .code,
            0);
  EXPECT_FALSE(fs::exists(d / "reducer_modes" / "campbell_orders.csv"));
  EXPECT_EQ(slurp(d / "reducer_modes" / "campbell_body.gp").find("logscale"), std::string::npos);
  const std::string amplitude = " --param 'train.speed[0].acceleration_harmonics[0][0]'";
  const Outcome sweep = cli("sweep " + c + amplitude + " --from 1000 --to 4000 --points 2 --out " +
                            (d / "sweep").string() + " --no-figures");
  ASSERT_EQ(sweep.code, 0) << sweep.err;
  const std::string csv = slurp(d / "sweep" / "sweep.csv");
  for (const char* column :
       {"clutch_impacts_per_period", "clutch_torque_nm_peak", "clutch_twist_rad_peak"})
    EXPECT_NE(csv.find(column), std::string::npos) << column;
  const Outcome orbit = cli("orbit " + c + " --json");
  ASSERT_EQ(orbit.code, 0) << orbit.err;
  const nlohmann::json o = nlohmann::json::parse(orbit.out);
  EXPECT_TRUE(o["converged"].get<bool>()) << o;
  EXPECT_EQ(o["clearances"][0]["name"], "clutch");
  const std::string idle = " --param 'train.damper[0].free_play_stiffness_n_m_per_rad'";
  const Outcome stability = cli("stability " + c + idle + " --from 7.5 --to 8.5 --points 2 --out " +
                                (d / "stability").string() + " --no-figures");
  ASSERT_EQ(stability.code, 0) << stability.err;
  const Outcome cont = cli("continue " + c + idle + " --from 8 --to 8.4 --out " +
                           (d / "continue").string() + " --no-figures");
  ASSERT_EQ(cont.code, 0) << cont.err;
  fs::remove_all(d);
}

// ---- geardyn validate (docs/validation.md) ----------------------------------------------

std::set<std::string> failing_checks(const nlohmann::json& j) {
  std::set<std::string> out;
  for (const auto& row : j["rows"])
    if (!row["passed"].get<bool>()) out.insert(row["check"].get<std::string>());
  return out;
}

TEST(Validate, EveryCheckPassesAndItsReportsAreWrittenBesideTheUsersFiles) {
  // The whole set, as a user runs it: a failing row fails this test (and so CI).
  const fs::path d = fresh("validate");
  fs::create_directories(d);
  std::ofstream(d / "notes.txt") << "mine";
  const Outcome o = cli("validate --out " + d.string());
  ASSERT_EQ(o.code, 0) << o.out << o.err;
  EXPECT_NE(o.out.find("0 failed"), std::string::npos) << o.out;
  EXPECT_EQ(slurp(d / "notes.txt"), "mine");
  const nlohmann::json j = nlohmann::json::parse(slurp(d / "validation.json"));
  EXPECT_TRUE(j["passed"].get<bool>());
  EXPECT_FALSE(j["quick"].get<bool>());
  EXPECT_TRUE(failing_checks(j).empty());
  // Every check ran and gave rows; every row names its source and has a finite error.
  std::set<std::string> with_rows;
  for (const auto& row : j["rows"]) {
    with_rows.insert(row["check"].get<std::string>());
    EXPECT_FALSE(row["source"].get<std::string>().empty()) << row["quantity"];
    EXPECT_TRUE(row["error"].is_number()) << row["quantity"];
  }
  const std::string md = slurp(d / "validation.md");
  const std::string docs = slurp(fs::path(GEARDYN_SOURCE_DIR) / "docs/validation.md");
  for (const auto& check : j["checks"]) {
    const std::string id = check["id"].get<std::string>();
    EXPECT_TRUE(with_rows.count(id)) << id;
    EXPECT_NE(md.find("(`" + id + "`)"), std::string::npos) << id;
    EXPECT_NE(docs.find("\n## " + id + "\n"), std::string::npos) << "docs/validation.md: " << id;
  }
  EXPECT_GT(j["rows"].size(), 100U);
  // The table on stdout has a line per row.
  std::size_t passes = 0;
  for (std::size_t at = o.out.find("\n  pass "); at != std::string::npos;
       at = o.out.find("\n  pass ", at + 1))
    ++passes;
  EXPECT_EQ(passes, j["rows"].size());
}

TEST(Validate, TheQuickSetComparesFewerCasesOfTheSameChecks) {
  const Outcome full = cli("validate --json");
  const Outcome quick = cli("validate --quick --json");
  ASSERT_EQ(full.code, 0) << full.err;
  ASSERT_EQ(quick.code, 0) << quick.err;
  const nlohmann::json f = nlohmann::json::parse(full.out), q = nlohmann::json::parse(quick.out);
  EXPECT_TRUE(q["quick"].get<bool>());
  EXPECT_TRUE(q["passed"].get<bool>());
  EXPECT_LT(q["rows"].size(), f["rows"].size());
  std::set<std::string> full_quantities;
  for (const auto& row : f["rows"])
    full_quantities.insert(row["check"].get<std::string>() + ": " +
                           row["quantity"].get<std::string>());
  // A quick row is a full row (the KS stable points are every 16th rather than every 8th).
  for (const auto& row : q["rows"])
    EXPECT_TRUE(full_quantities.count(row["check"].get<std::string>() + ": " +
                                      row["quantity"].get<std::string>()))
        << row["quantity"];
}

TEST(Validate, CtrlCStopsAfterTheCheckUnderWayAndReportsTheChecksDone) {
  // Ctrl-C once three checks are done (a SIGINT the tool sends itself through its own handler,
  // GEARDYN_TEST_SIGINT_AFTER_CHECKS: a kill from outside after a fixed time raced a machine
  // that runs the whole set in under a second) stops it there: exit 130 and reports of what ran.
  const fs::path d = fresh("validate_interrupt");
  const Outcome o = shell("GEARDYN_TEST_SIGINT_AFTER_CHECKS=3 " + std::string(GEARDYN_CLI) +
                          " validate --out " + d.string());
  EXPECT_EQ(o.code, 130) << o.err;
  EXPECT_NE(o.err.find("interrupted: reporting the"), std::string::npos) << o.err;
  const nlohmann::json j = nlohmann::json::parse(slurp(d / "validation.json"));
  EXPECT_TRUE(j["cancelled"].get<bool>());
  EXPECT_FALSE(j["passed"].get<bool>());
  EXPECT_EQ(j["checks_run"].get<int>(), 3);
  EXPECT_LT(j["checks_run"].get<int>(), j["checks_total"].get<int>());
  EXPECT_TRUE(failing_checks(j).empty());  // what ran, passed
}

TEST(Validate, ItsHtmlReportRendersItsTableInAHeadlessBrowser) {
  const fs::path d = fresh("validate_html");
  ASSERT_EQ(cli("validate --quick --out " + d.string()).code, 0);
  const nlohmann::json j = nlohmann::json::parse(slurp(d / "validation.json"));
  const std::string url = "file://" + fs::absolute(d / "validation.html").string();
  const std::string browser = "chromium --headless --no-sandbox --disable-gpu ";
  const Outcome dom = shell(browser + "--dump-dom " + url);
  ASSERT_EQ(dom.code, 0) << dom.err;
  std::size_t rows = 0;
  for (std::size_t at = dom.out.find("<tr class=\"pass\">"); at != std::string::npos;
       at = dom.out.find("<tr class=\"pass\">", at + 1))
    ++rows;
  EXPECT_EQ(rows, j["rows"].size());
  EXPECT_NE(dom.out.find("<table id=\"validation\">"), std::string::npos);
  // Drawn: a screenshot of the table is far from a blank page's (about 5 kB).
  const fs::path png = d / "shot.png";
  const Outcome shot =
      shell(browser + "--window-size=1200,900 --screenshot=" + png.string() + " " + url);
  ASSERT_EQ(shot.code, 0) << shot.err;
  ASSERT_TRUE(fs::exists(png));
  EXPECT_GT(fs::file_size(png), 50000U);
}

}  // namespace

namespace {

// A planetary set written for its modes carries no load: its run's figures are drawn all the
// same, the load-sharing panels saying there is no factor instead of plotting an undefined one
// (gnuplot failed on it, exit 3, when every shipped case's figures were first drawn).
TEST(Cli, AnUnloadedPlanetarySetsFiguresSayItHasNoLoadSharingFactor) {
  const fs::path d = fresh("unloaded_planetary");
  const Outcome o = cli("run " + case_path("lin_parker_1999.toml") +
                        " --set solver.duration_s=0.01 --plot --out " + d.string());
  ASSERT_EQ(o.code, 0) << o.err;
  EXPECT_TRUE(fs::exists(d / "load_sharing.png"));
  const std::string body = slurp(d / "load_sharing_body.gp");
  EXPECT_NE(body.find("no factor: its meshes carry no load"), std::string::npos) << body;
  EXPECT_EQ(body.find("title 'factor'"), std::string::npos) << body;
  fs::remove_all(d);
}

}  // namespace
