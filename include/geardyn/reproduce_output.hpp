// geardyn: the report of a reproduced study (reproduce_output.cpp), output layer.
#pragma once

#include <cstddef>
#include <filesystem>
#include <string>

#include "geardyn/reproduce.hpp"

namespace geardyn {

// What holds over which windows, in one paragraph (the report's and the command's headline).
std::string study_headline(const StudyResult& r);

// How many findings hold over a window, from the scan.
std::size_t holding_at(const StudyResult& r, double window_s);

// The report, from the outcomes: Markdown and HTML (the HTML embeds the figures by file name).
std::string report_markdown(const StudyResult& r);
std::string report_html(const StudyResult& r);

// Writes DIR/report.md, DIR/report.html, DIR/study.json, DIR/cases/<id>/ (each run's files),
// and, with `figures`, one figure per paper figure (DIR/fig4.png, .svg, .gp ...), the panels as
// in the paper, as one named set "reproduce <study>" (output_folder.hpp: the user's files in DIR
// stay, the study's earlier files are replaced together). Throws FigureError if gnuplot fails,
// with the data in place.
void write_study(const std::filesystem::path& dir, const StudyResult& r, bool figures = true);

}  // namespace geardyn
