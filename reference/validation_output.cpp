// The reports of `geardyn validate` (validation_output.hpp): a terminal table, Markdown,
// self-contained HTML and JSON, and the output set they are written as.
#include "geardyn/validation_output.hpp"

#include <fmt/format.h>

#include <algorithm>
#include <cmath>
#include <nlohmann/json.hpp>
#include <string>
#include <vector>

#include "geardyn/output.hpp"
#include "geardyn/output_folder.hpp"

namespace geardyn {

// ---- reports -----------------------------------------------------------------------------

namespace {

const ValidationCheck& check_info(const std::string& id) {
  for (const ValidationCheck& c : validation_checks())
    if (c.id == id) return c;
  throw std::logic_error("no validation check " + id);
}

std::string error_text(const ValidationRow& r) {
  return std::isfinite(r.error) ? fmt::format("{:.2e}", r.error) : "-";
}

std::string headline(const ValidationResult& r) {
  const std::size_t failed = r.failures();
  return fmt::format(
      "{} checks{}, {} rows: {} passed, {} failed{} ({:.1f} s)", r.checks_run,
      r.quick ? " (quick)" : "", r.rows.size(), r.rows.size() - failed, failed,
      r.cancelled ? fmt::format("; interrupted after {} of {} checks", r.checks_run, r.checks_total)
                  : "",
      r.wall_time_s);
}

std::string md_cell(const std::string& s) {
  std::string out;
  for (const char ch : s) out += ch == '|' ? std::string("\\|") : std::string(1, ch);
  return out;
}

}  // namespace

std::string validation_table(const ValidationResult& r) {
  // One line a row, in columns as wide as their widest cell, under a line per check.
  const auto cells = [](const ValidationRow& row) {
    return std::array<std::string, 6>{row.passed ? "pass" : "FAIL",
                                      row.quantity,
                                      row.value,
                                      row.reference,
                                      fmt::format("{} {}", error_text(row), row.measure),
                                      fmt::format("{:.1e}", row.tolerance)};
  };
  const std::array<std::string, 6> head = {"",          "quantity", "geardyn",
                                           "reference", "error",    "tolerance"};
  std::array<std::size_t, 6> width{};
  for (std::size_t i = 0; i < head.size(); ++i) width[i] = head[i].size();
  for (const ValidationRow& row : r.rows) {
    const auto c = cells(row);
    for (std::size_t i = 0; i < c.size(); ++i) width[i] = std::max(width[i], c[i].size());
  }
  const auto line = [&](const std::array<std::string, 6>& c, const std::string& source) {
    std::string out = " ";
    for (std::size_t i = 0; i < c.size(); ++i) out += fmt::format(" {:<{}}", c[i], width[i]);
    return out + "  " + source + "\n";
  };
  std::string out = line(head, "reference's source");
  std::string last;
  for (const ValidationRow& row : r.rows) {
    if (row.check != last) {
      out += fmt::format("{} ({})\n", check_info(row.check).title, row.check);
      last = row.check;
    }
    out += line(cells(row), (row.cited ? "cited: " : "") + row.source);
  }
  return out + headline(r) + "\n";
}

std::string validation_markdown(const ValidationResult& r) {
  std::string out = "# geardyn validation\n\n" + headline(r) +
                    ". Each check is described in docs/validation.md under its name.\n";
  std::string last;
  for (const ValidationRow& row : r.rows) {
    if (row.check != last) {
      out += fmt::format(
          "\n## {} (`{}`)\n\n| quantity | geardyn | reference | source | error | measure | "
          "tolerance | result |\n|---|---|---|---|---|---|---|---|\n",
          check_info(row.check).title, row.check);
      last = row.check;
    }
    out += fmt::format("| {} | {} | {} | {}{} | {} | {} | {:.1e} | {} |\n", md_cell(row.quantity),
                       md_cell(row.value), md_cell(row.reference), row.cited ? "cited: " : "",
                       md_cell(row.source), error_text(row), row.measure, row.tolerance,
                       row.passed ? "pass" : "**FAIL**");
  }
  return out;
}

std::string validation_html(const ValidationResult& r) {
  std::string out =
      "<!DOCTYPE html>\n<html lang=\"en\"><head><meta charset=\"utf-8\">"
      "<title>geardyn validation</title><style>"
      "body{font-family:sans-serif;margin:2em}table{font-size:0.9em}"
      "table{border-collapse:collapse;width:100%}td,th{border:1px solid #bbb;padding:0.3em;"
      "text-align:left;vertical-align:top}th{background:#eee}"
      ".pass{color:#060}.fail{color:#b00;font-weight:bold}</style></head><body>\n"
      "<h1>geardyn validation</h1>\n<p id=\"headline\">" +
      html_escape(headline(r)) +
      "</p>\n<p>Each check is described in docs/validation.md under its name.</p>\n"
      "<table id=\"validation\"><thead><tr><th>check</th><th>quantity</th><th>geardyn</th>"
      "<th>reference</th><th>source</th><th>error</th><th>measure</th><th>tolerance</th>"
      "<th>result</th></tr></thead><tbody>\n";
  for (const ValidationRow& row : r.rows)
    out += fmt::format(
        "<tr class=\"{}\"><td>{}</td><td>{}</td><td>{}</td><td>{}</td><td>{}{}</td><td>{}</td>"
        "<td>{}</td><td>{:.1e}</td><td>{}</td></tr>\n",
        row.passed ? "pass" : "fail", html_escape(row.check), html_escape(row.quantity),
        html_escape(row.value), html_escape(row.reference), row.cited ? "cited: " : "",
        html_escape(row.source), error_text(row), html_escape(row.measure), row.tolerance,
        row.passed ? "pass" : "FAIL");
  return out + "</tbody></table>\n</body></html>\n";
}

std::string validation_json(const ValidationResult& r) {
  nlohmann::ordered_json j;
  j["passed"] = r.passed();
  j["quick"] = r.quick;
  j["cancelled"] = r.cancelled;
  j["checks_run"] = r.checks_run;
  j["checks_total"] = r.checks_total;
  j["failures"] = r.failures();
  j["wall_time_s"] = r.wall_time_s;
  nlohmann::ordered_json checks = nlohmann::ordered_json::array();
  for (const ValidationCheck& c : validation_checks())
    checks.push_back({{"id", c.id}, {"title", c.title}, {"quick", c.quick}});
  j["checks"] = checks;
  nlohmann::ordered_json rows = nlohmann::ordered_json::array();
  for (const ValidationRow& row : r.rows)
    rows.push_back({{"check", row.check},
                    {"quantity", row.quantity},
                    {"value", row.value},
                    {"reference", row.reference},
                    {"source", row.source},
                    {"cited", row.cited},
                    {"error", std::isfinite(row.error) ? nlohmann::ordered_json(row.error)
                                                       : nlohmann::ordered_json(nullptr)},
                    {"measure", row.measure},
                    {"tolerance", row.tolerance},
                    {"passed", row.passed}});
  j["rows"] = rows;
  return j.dump(2) + "\n";
}

std::vector<std::string> write_validation(const std::filesystem::path& dir,
                                          const ValidationResult& r) {
  return write_set(dir, "validate", [&](const std::filesystem::path& staging) {
    write_files_atomically(staging, {{"validation.md", validation_markdown(r)},
                                     {"validation.html", validation_html(r)},
                                     {"validation.json", validation_json(r)}});
  });
}

}  // namespace geardyn
