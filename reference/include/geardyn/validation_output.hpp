// geardyn: the reports of the validation (validation_output.cpp). A reference: in the
// geardyn_reference library (reference/), linked by `geardyn validate` and the tests alone.
#pragma once

#include <filesystem>
#include <string>
#include <vector>

#include "geardyn/validation.hpp"

namespace geardyn {

// The result as a terminal table, Markdown, self-contained HTML (no scripts, no external
// files: readable offline) and JSON.
std::string validation_table(const ValidationResult& r);
std::string validation_markdown(const ValidationResult& r);
std::string validation_html(const ValidationResult& r);
std::string validation_json(const ValidationResult& r);

// Writes DIR/validation.md, validation.html and validation.json as the named set "validate"
// (output_folder.hpp: the user's files in DIR are never touched). Returns the files of an
// earlier set kept because the user changed them (write_set).
std::vector<std::string> write_validation(const std::filesystem::path& dir,
                                          const ValidationResult& r);

}  // namespace geardyn
