// geardyn (private): where a TOML node came from and its text, for the messages of the case
// readers (case.cpp, train_case.cpp).
#pragma once

#include <toml++/toml.h>

#include <string>
#include <string_view>
#include <vector>

#include "geardyn/case.hpp"

namespace geardyn {

// "case.toml:12:5", or the --set that wrote the node (parse_toml names its source so), or
// `fallback` when the node has no place.
std::string where(const toml::source_region& src, const std::string& fallback);
// Where the value of a dotted key came from: the last --set that wrote it or anything under it
// (overrides in order), else the node's place (where).
std::string origin_of(const std::vector<Override>& overrides, const std::string& dotted,
                      const toml::source_region& src, const std::string& source);
// The node's value as TOML text on one line (strings quoted, control characters escaped).
std::string node_text(const toml::node& n);
// A user's text as a message shows it: each control character escaped (\n, \t, \r, \uXXXX),
// so that a message stays one line and shows what was written.
std::string printable(std::string_view text);
// The document of a case file or a --set: `text` without a byte-order mark, parsed with
// `source` as its path in messages.
toml::table parse_toml(const std::string& text, const std::string& source);

struct TrainCase;
// The [train] table of a case file (train_case.cpp). Throws InputError naming where.
TrainCase read_train_case(const toml::node& train, const std::string& source,
                          const std::vector<Override>& overrides);

}  // namespace geardyn
