// The case reader and the --set parser under fuzzing: any input either reads as a case or is
// refused with an InputError; anything else (another exception, a crash, a sanitizer report,
// a hang) is a defect. Built for libFuzzer by scripts/fuzz.sh (clang), and replayed with
// mutations by fuzz/replay_main.cpp in the tests (any compiler).
//
// The input: the text of a case file; its first line is also tried as a --set assignment. A
// gear train's case is also assembled (train_case.hpp), its arrangement checked.
#include <cstddef>
#include <cstdint>
#include <string>

#include "geardyn/case.hpp"
#include "geardyn/case_keys.hpp"
#include "geardyn/train_case.hpp"

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  const std::string text(reinterpret_cast<const char*>(data), size);
  try {
    const geardyn::Case c = geardyn::parse_case(text, "fuzz.toml");
    (void)geardyn::unused_settings(c);
    (void)geardyn::parse_case(geardyn::to_toml(c), "fuzz.toml (written back)");
    // A train is assembled too: its arrangement is checked there.
    if (c.train) (void)geardyn::assembled_train(c);
  } catch (const geardyn::InputError&) {
  }
  const std::string first_line = text.substr(0, text.find('\n'));
  try {
    (void)geardyn::load_case(std::nullopt, {geardyn::parse_override(first_line)});
  } catch (const geardyn::InputError&) {
  }
  return 0;
}
