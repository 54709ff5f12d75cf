#include "geardyn/output.hpp"

#include <fmt/format.h>

#include <cstdio>
#include <fstream>
#include <nlohmann/json.hpp>
#include <random>
#include <sstream>
#include <stdexcept>
#include <string_view>

#include "geardyn/case_keys.hpp"
#include "geardyn/csv.hpp"

namespace geardyn {
namespace {

nlohmann::json optional_number(const std::optional<double>& x) {
  if (x && std::isfinite(*x)) return *x;
  return nullptr;
}

nlohmann::json finite_or_null(double x) {
  if (std::isfinite(x)) return x;
  return nullptr;
}

// The keys of a reading (over the whole window, or over the steady part).
nlohmann::json reading_json(const RunReading& x) {
  return {
      {"regime", to_string(x.regime)},
      {"double_sided", x.double_sided},
      {"impacts", x.impacts},
      {"backside_impacts", x.backside_impacts},
      {"separations", x.separations},
      {"last_separation_s", optional_number(x.last_separation_s)},
      {"separated_fraction", x.separated_fraction},
      {"max_impact_velocity_m_s", x.max_impact_velocity_m_s},
      {"max_force_bar", finite_or_null(x.max_force_bar)},
      {"min_force_bar", finite_or_null(x.min_force_bar)},
      {"mean_force_bar", x.mean_force_bar},
      {"rms_force_bar", x.rms_force_bar},
      {"max_delta_bar", finite_or_null(x.max_delta_bar)},
      {"min_delta_bar", finite_or_null(x.min_delta_bar)},
      {"mean_delta_bar", x.mean_delta_bar},
      {"rms_delta_bar", x.rms_delta_bar},
      {"dynamic_factor", optional_number(x.dynamic_factor)},
  };
}

// Every key of a JSON value renamed by form_key.
nlohmann::json in_form(const nlohmann::json& j, ModelForm form) {
  if (j.is_object()) {
    nlohmann::json out = nlohmann::json::object();
    for (const auto& [key, value] : j.items()) out[form_key(key, form)] = in_form(value, form);
    return out;
  }
  if (j.is_array()) {
    nlohmann::json out = nlohmann::json::array();
    for (const auto& value : j) out.push_back(in_form(value, form));
    return out;
  }
  return j;
}

}  // namespace

std::string geometry_json(const Geometry& g) {
  constexpr double kDeg = 180.0 / 3.14159265358979323846;
  constexpr double kMm = 1e3;
  auto pair_mm = [](const std::array<double, 2>& x, double f) {
    return nlohmann::json::array({x[0] * f, x[1] * f});
  };
  const nlohmann::json j = {
      {"transverse_module_mm", g.transverse_module_m * kMm},
      {"transverse_pressure_angle_deg", g.transverse_pressure_angle_rad * kDeg},
      {"base_helix_angle_deg", g.base_helix_angle_rad * kDeg},
      {"reference_diameter_mm", pair_mm(g.reference_diameter_m, kMm)},
      {"base_diameter_mm", pair_mm(g.base_radius_m, 2 * kMm)},
      {"root_diameter_mm", pair_mm(g.root_diameter_m, kMm)},
      {"expected_outside_diameter_mm", pair_mm(g.expected_outside_diameter_m, kMm)},
      {"reference_center_distance_mm", g.reference_center_distance_m * kMm},
      {"center_distance_mm", g.center_distance_m * kMm},
      {"shift_center_distance_mm", g.shift_center_distance_m * kMm},
      {"working_pressure_angle_deg", g.working_pressure_angle_rad * kDeg},
      {"shift_working_pressure_angle_deg", g.shift_working_pressure_angle_rad * kDeg},
      {"transverse_base_pitch_mm", g.transverse_base_pitch_m * kMm},
      {"transverse_contact_ratio", g.transverse_contact_ratio},
      {"overlap_ratio", g.overlap_ratio},
      {"total_contact_ratio", g.total_contact_ratio()},
      {"inertia_kg_m2", pair_mm(g.inertia_kg_m2, 1.0)},
      {"m_eq_kg", g.equivalent_mass_kg},
      {"warnings", g.warnings},
  };
  return j.dump(2);
}

std::string summary_json(const RunResult& r, int indent) {
  const RunReading& x = r.reading;
  const Derived& d = r.derived;
  nlohmann::json j;
  j["case"] = r.input.name;
  j["termination"] = ode::to_string(r.integration.termination);
  j["message"] = r.integration.message;
  j.update(reading_json(x));
  // The dynamic factor is the steady one; the whole window's, start-up included, beside it.
  j["dynamic_factor"] = optional_number(r.steady.reading.dynamic_factor);
  j["dynamic_factor_with_startup"] = optional_number(x.dynamic_factor);
  nlohmann::json steady = reading_json(r.steady.reading);
  steady["basis"] = to_string(r.steady.basis);
  if (r.steady.window_s > 0) steady["window_s"] = r.steady.window_s;
  steady["from_s"] = r.steady.from_s;
  steady["period_multiple"] = r.steady.period_multiple;
  steady["steady_error"] = finite_or_null(r.steady.error);
  j["steady"] = steady;
  j["steps"] = r.integration.steps;
  j["transitions"] = r.integration.transitions;
  j["unsplit_steps"] = r.integration.unsplit_steps;
  j["method"] = to_string(r.input.solver.method);
  j["duration_s"] = r.input.solver.duration_s;
  j["wall_time_s"] = r.wall_time_s;
  j["warnings"] = r.geometry.warnings;
  j["unused_settings"] = unused_settings(r.input);
  auto peaks = [](const std::vector<SpectralPeak>& p) {
    nlohmann::json a = nlohmann::json::array();
    for (const SpectralPeak& x : p)
      a.push_back({{"frequency_hz", x.frequency_hz}, {"amplitude", x.amplitude}});
    return a;
  };
  j["spectrum"] = {{"steady_start_s", r.steady_start_s},
                   {"force_bar", peaks(r.force_peaks)},
                   {"delta_bar", peaks(r.delta_peaks)}};
  j["derived"] = {
      {"m_eq_kg", d.m_eq_kg},
      {"natural_frequency_hz", d.natural_frequency_hz},
      {"damping_n_s_per_m", d.damping_n_s_per_m},
      {"mean_force_n", d.mean_force_n},
      {"static_delta_bar", d.static_delta_bar},
      {"mesh_frequency_hz", d.mesh_frequency_hz},
      {"base_helix_angle_deg", d.base_helix_angle_deg},
      {"working_pressure_angle_deg", d.working_pressure_angle_deg},
      {"transverse_contact_ratio", d.transverse_contact_ratio},
      {"overlap_ratio", d.overlap_ratio},
      {"fastest_period_s", d.fastest_period_s},
      {"time_step_s", d.time_step_s},
      {"output_interval_s", d.output_interval_s},
  };
  nlohmann::json te = nlohmann::json::array();
  for (std::size_t i = 0; i < d.transmission_error_um.size(); ++i)
    te.push_back({{"order", i + 1},
                  {"amplitude_um", d.transmission_error_um[i].amplitude},
                  {"phase_deg", d.transmission_error_um[i].phase_deg}});
  j["derived"]["transmission_error"] = {{"mean_um", d.transmission_error_mean_um},
                                        {"harmonics", te}};
  return in_form(j, r.input.model.form).dump(indent);
}

void write_timeseries_csv(std::ostream& out, const Timeseries& s, ModelForm form) {
  out << fmt::format("{},delta_bar,{},force_bar,contact\n", form_key("t_s", form),
                     form_key("velocity_m_s", form));
  write_csv_rows(out, s.size(), [&s](CsvWriter& csv, std::size_t i) {
    csv.number(s.t_s[i]).number(s.delta_bar[i]).number(s.velocity_m_s[i]).number(s.force_bar[i]);
    csv.integer(s.contact[i]).end_row();
  });
}

std::string timeseries_csv(const Timeseries& s, ModelForm form) {
  std::ostringstream out;
  write_timeseries_csv(out, s, form);
  return out.str();
}

std::string spectrum_csv(const RunResult& r) {
  std::string out = "frequency_hz,force_bar_amplitude,delta_bar_amplitude\n";
  const Spectrum& f = r.force_spectrum;
  const Spectrum& d = r.delta_spectrum;
  for (std::size_t k = 0; k < f.frequency_hz.size() && k < d.amplitude.size(); ++k)
    fmt::format_to(std::back_inserter(out), "{:.10g},{:.6e},{:.6e}\n", f.frequency_hz[k],
                   f.amplitude[k], d.amplitude[k]);
  return out;
}

std::string events_csv(const std::vector<ContactEvent>& events, ModelForm form) {
  std::string out =
      fmt::format("{},kind,{}\n", form_key("t_s", form), form_key("velocity_m_s", form));
  for (const ContactEvent& e : events)
    fmt::format_to(std::back_inserter(out), "{:.15g},{},{:.10g}\n", e.t_s, to_string(e.kind),
                   e.velocity_m_s);
  return out;
}

std::string stiffness_json(const Case& c, const Geometry& g, const Iso6336Stiffness& iso,
                           const StiffnessCycle& cycle, const StiffnessFourier& fourier) {
  nlohmann::json harmonics = nlohmann::json::array();
  for (const StiffnessHarmonic& h : fourier.harmonics) harmonics.push_back({h.ratio, h.phase_deg});
  nlohmann::json j;
  j["iso6336"] = {{"q_prime", iso.q_prime},
                  {"c_prime_th", iso.c_prime_th},
                  {"c_prime", iso.c_prime},
                  {"c_gamma_alpha", iso.c_gamma_alpha},
                  {"c_gamma_beta", iso.c_gamma_beta},
                  {"unit", "N/(mm um)"},
                  {"virtual_teeth", iso.virtual_teeth},
                  {"c_m", iso.c_m},
                  {"c_r", iso.c_r},
                  {"c_b", iso.c_b},
                  {"material_factor", iso.material_factor},
                  {"load_factor", iso.load_factor},
                  {"mesh_stiffness_n_per_m", iso.mesh_stiffness_n_per_m}};
  j["energy"] = {{"mean_n_per_m", cycle.mean_n_per_m()},
                 {"min_n_per_m", cycle.min_n_per_m()},
                 {"max_n_per_m", cycle.max_n_per_m()},
                 {"harmonics", harmonics},
                 {"harmonics_kept", fourier.harmonics.size()},
                 {"truncation_error", truncation_error(cycle, fourier)},
                 {"mean_pairs_in_contact", cycle.mean_pairs_in_contact()},
                 {"positions", cycle.position.size()},
                 {"slices", c.mesh.stiffness_slices}};
  j["geometry"] = {{"transverse_contact_ratio", g.transverse_contact_ratio},
                   {"overlap_ratio", g.overlap_ratio},
                   {"base_helix_angle_deg", g.base_helix_angle_rad * 180.0 / 3.14159265358979}};
  j["case_mean_stiffness_n_per_m"] = c.mesh.mean_stiffness_n_per_m;
  return j.dump(2);
}

std::string stiffness_csv(const Geometry& g, const StiffnessCycle& cycle,
                          const StiffnessFourier& fourier, const StiffnessFourier& used) {
  std::string out =
      "position,position_mm,total_n_per_m,series_n_per_m,used_n_per_m,pairs_in_contact,"
      "contact_length_mm";
  for (std::size_t j = 0; j < cycle.pair_n_per_m.size(); ++j)
    fmt::format_to(std::back_inserter(out), ",pair_{}_n_per_m", j);
  out += "\n";
  for (std::size_t n = 0; n < cycle.position.size(); ++n) {
    const double series = fourier.at(cycle.position[n]);
    fmt::format_to(std::back_inserter(out), "{:.6f},{:.6f},{:.8e},{:.8e},{:.8e},{},{:.6f}",
                   cycle.position[n], cycle.position[n] * g.transverse_base_pitch_m * 1e3,
                   cycle.total_n_per_m[n], series, used.at(cycle.position[n]),
                   n < cycle.pairs_in_contact.size() ? cycle.pairs_in_contact[n] : 0,
                   n < cycle.contact_length_m.size() ? cycle.contact_length_m[n] * 1e3 : 0.0);
    for (const auto& pair : cycle.pair_n_per_m)
      fmt::format_to(std::back_inserter(out), ",{:.8e}", pair[n]);
    out += "\n";
  }
  return out;
}

void write_run(const std::filesystem::path& dir, const RunResult& r) {
  // The samples are streamed: up to kMaxSamples rows, never a second copy in memory.
  const std::string summary = summary_json(r) + "\n",
                    events = events_csv(r.events, r.input.model.form), toml = to_toml(r.input);
  const auto text = [](const std::string& t) { return [&t](std::ostream& out) { out << t; }; };
  write_files_atomically(
      dir,
      std::vector<std::pair<std::string, FileWriter>>{
          {"summary.json", text(summary)},
          {"timeseries.csv",
           [&r](std::ostream& out) { write_timeseries_csv(out, r.samples, r.input.model.form); }},
          {"events.csv", text(events)},
          {"case.toml", text(toml)}});
}

std::string html_escape(const std::string& s) {
  std::string out;
  for (char c : s) {
    switch (c) {
      case '<':
        out += "&lt;";
        break;
      case '>':
        out += "&gt;";
        break;
      case '&':
        out += "&amp;";
        break;
      case '"':
        out += "&quot;";
        break;
      default:
        out += c;
    }
  }
  return out;
}

}  // namespace geardyn
