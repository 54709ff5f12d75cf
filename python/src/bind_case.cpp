#include <fmt/format.h>
#include <pybind11/stl.h>
#include <pybind11/stl/filesystem.h>

#include "bindings.hpp"
#include "geardyn/case.hpp"
#include "geardyn/case_keys.hpp"
#include "geardyn/train_case.hpp"
#include "geardyn/train_presets.hpp"

namespace py = pybind11;

namespace geardyn::python {

// Where a key given to Case(**keys) came from, in messages: the call (there is no file, line or
// column to name; case.hpp, kPositionlessSources).
constexpr const char* kPythonCaseSource = "Case(...)";

void bind_case(py::module_& m) {
  py::class_<Case>(m, "Case", "A case: everything a run needs (docs/case-files.md).")
      .def(py::init([](const py::kwargs& keys) {
             // The defaults, then each key (dotted, or a section's dict) converted to TOML by
             // the Python layer.
             // A gear train's keys are read together, as one case file.
             const py::object document =
                 py::module_::import("geardyn").attr("_case_document")(keys);
             if (!document.is_none())
               return parse_case(document.cast<std::string>(), kPythonCaseSource);
             Case c = load_case(std::nullopt);
             const py::list pairs = py::module_::import("geardyn").attr("_case_overrides")(keys);
             for (const py::handle& kv : pairs) {
               const auto t = kv.cast<std::pair<std::string, std::string>>();
               set_case_value(c, {t.first, t.second, kPythonCaseSource});
             }
             return c;
           }),
           "A case: the defaults (the paper's Table 1 at Fig. 4(c)) with keys set.\n\n"
           "Parameters\n----------\n"
           "**keys\n"
           "    Sections as dicts, ``Case(speed={'shaft_frequency_hz': 100})``, or dotted keys,\n"
           "    ``Case(**{'mesh.backlash_um': 150})``; each in the unit its name ends with\n"
           "    (docs/case-files.md).\n\n"
           "Raises\n------\nInputError\n    A key that does not exist or a value out of range.")
      .def(
          "__eq__", [](const Case& a, const Case& b) { return to_toml(a) == to_toml(b); },
          py::is_operator())
      .def_static(
          "from_toml", [](const std::filesystem::path& path) { return load_case(path); },
          py::arg("path"),
          "Reads a case file.\n\n"
          "Parameters\n----------\npath : str or path-like\n    A TOML case file; relative paths "
          "in it start at its directory.\n\n"
          "Returns\n-------\nCase\n\n"
          "Raises\n------\nInputError\n    Bad input, naming file, line, key and value.")
      .def_static(
          "default", [] { return load_case(std::nullopt); },
          "The default case: the paper's gear, Table 1 at the conditions of Fig. 4(c).\n\n"
          "Returns\n-------\nCase")
      .def(
          "set_toml",
          [](Case& c, const std::string& key, const std::string& toml_value,
             const std::string& origin) {
            set_case_value(c, {key, toml_value, origin});
          },
          py::arg("key"), py::arg("toml_value"), py::arg("origin") = std::string(),
          "Sets a key in place from a value in TOML syntax, as ``--set key=value`` does.\n\n"
          "Parameters\n----------\nkey : str\n    A dotted key, e.g. "
          "``\"mesh.backlash_um\"``.\n"
          "toml_value : str\n    The value as TOML text (``\"150\"``, ``\"[[0.1, 0]]\"``); bare "
          "text is taken as a string.\n"
          "origin : str, optional\n    How the user gave it, for messages (default: the "
          "``--set`` it is).\n\n"
          "Raises\n------\nInputError\n    A key that does not exist or a value out of range.")
      .def(
          "_unread_study_key",
          [](const Case& c,
             const std::vector<std::vector<std::pair<std::string, double>>>& corners) {
            std::vector<std::vector<Override>> sets;
            for (const auto& corner : corners) {
              std::vector<Override>& set = sets.emplace_back();
              for (const auto& [key, value] : corner)
                set.push_back({key, fmt::format("{:.17g}", value),
                               fmt::format("inputs.{} = {:g}", key, value)});
            }
            return unread_study_key(c, sets);
          },
          py::arg("corners"),
          "The first key of every corner (a list of (key, value) the study sets together), when it "
          "is unused at all of them: its unused line; else \"\" (case_keys.hpp, "
          "unread_study_key).")
      .def(
          "_unused_settings",
          [](const Case& c, bool exact_engine) {
            return unused_settings(
                c, exact_engine ? Integration::kExactEngine : Integration::kCaseMethod);
          },
          py::arg("exact_engine") = false,
          "Each setting of the case that its form or method does not read, as the command "
          "line warns of it (case_keys.hpp, unused_settings); with exact_engine, also the "
          "method's keys, for a study that integrates with the exact engine whatever the method.")
      .def(
          "to_toml", [](const Case& c) { return to_toml(c); },
          "Every key of the case as TOML text, numbers to 17 significant digits (a case file "
          "that reads back equal).\n\nReturns\n-------\nstr")
      .def_readwrite("name", &Case::name,
                     "The case's name (the file's stem; written to summary.json).")
      .def(
          "train_form", [](const Case& c) { return train_form_of(c); },
          "The case as a gear train of elements (``model.form = \"train\"``), as ``geardyn "
          "train-form`` prints it: the same gears, mesh, loads and bearings, whose run is the "
          "case's (docs/case-files.md, \"Gear trains\").\n\n"
          "Returns\n-------\nCase\n\n"
          "Raises\n------\nInputError\n    A form the train does not model (nondimensional, "
          "dof 6, damping \"always\", tension \"clip\"), naming the key.")
      .def(
          "copy", [](const Case& c) { return Case(c); },
          "An independent copy.\n\nReturns\n-------\nCase")
      .def("__repr__", [](const Case& c) { return "<geardyn.Case " + c.name + ">"; })
      .def_property_readonly(
          "directory", [](const Case& c) { return c.directory.string(); },
          "The case file's directory: relative paths in the case start there.")
      // Pickled as its TOML, name and directory: exact (every number to 17 digits).
      .def(py::pickle(
          [](const Case& c) { return py::make_tuple(to_toml(c), c.name, c.directory.string()); },
          [](const py::tuple& t) {
            if (t.size() != 3) throw InputError("a pickled geardyn.Case holds three items");
            Case c = parse_case(t[0].cast<std::string>(), "(pickled case)");
            c.name = t[1].cast<std::string>();
            c.directory = t[2].cast<std::string>();
            return c;
          }));
}

}  // namespace geardyn::python
