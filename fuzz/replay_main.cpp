// A driver for the fuzz target without libFuzzer: runs every seed file given, then `runs`
// mutations of them (byte flips, insertions, deletions, splices; a fixed random seed, so a
// failure repeats). Exit 1, with the input in hex, when the target throws anything but an
// InputError. Usage: case_reader_fuzz_replay RUNS SEED FILE_OR_DIR...
#include <cstdint>
#include <cstdio>
#include <exception>
#include <filesystem>
#include <fstream>
#include <random>
#include <sstream>
#include <string>
#include <vector>

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size);

namespace {

std::string slurp(const std::filesystem::path& p) {
  std::ifstream in(p, std::ios::binary);
  std::ostringstream s;
  s << in.rdbuf();
  return s.str();
}

bool survives(const std::string& input) {
  try {
    LLVMFuzzerTestOneInput(reinterpret_cast<const std::uint8_t*>(input.data()), input.size());
    return true;
  } catch (const std::exception& e) {
    std::fprintf(stderr, "an exception escaped the reader: %s\ninput (%zu bytes, hex):", e.what(),
                 input.size());
    for (unsigned char ch : input) std::fprintf(stderr, " %02x", ch);
    std::fprintf(stderr, "\n");
    return false;
  }
}

}  // namespace

int main(int argc, char** argv) {
  if (argc < 4) {
    std::fprintf(stderr, "usage: %s RUNS SEED FILE_OR_DIR...\n", argv[0]);
    return 2;
  }
  const long runs = std::stol(argv[1]);
  std::mt19937_64 rng(std::stoull(argv[2]));
  std::vector<std::string> seeds;
  for (int i = 3; i < argc; ++i) {
    const std::filesystem::path p = argv[i];
    if (std::filesystem::is_directory(p)) {
      for (const auto& e : std::filesystem::directory_iterator(p))
        if (e.is_regular_file()) seeds.push_back(slurp(e.path()));
    } else {
      seeds.push_back(slurp(p));
    }
  }
  if (seeds.empty()) {
    std::fprintf(stderr, "no seeds\n");
    return 2;
  }
  for (const std::string& s : seeds)
    if (!survives(s)) return 1;
  // Bytes a mutation inserts: TOML's syntax, digits, and the bytes that found defects.
  const std::string alphabet = "[]{}=\"'#.,-+_ \n\t0123456789eEinfatrus\x00\xce\xbc\xff";
  std::uniform_int_distribution<int> pick(0, 4);
  for (long r = 0; r < runs; ++r) {
    std::string x = seeds[rng() % seeds.size()];
    const int edits = 1 + static_cast<int>(rng() % 8);
    for (int k = 0; k < edits; ++k) {
      const std::size_t at = x.empty() ? 0 : rng() % (x.size() + 1);
      switch (pick(rng)) {
        case 0:  // flip a byte
          if (at < x.size()) x[at] = static_cast<char>(rng() & 0xff);
          break;
        case 1:  // insert a syntax byte
          x.insert(at, 1, alphabet[rng() % alphabet.size()]);
          break;
        case 2:  // delete a stretch
          if (at < x.size()) x.erase(at, 1 + rng() % 16);
          break;
        case 3: {  // splice in a stretch of another seed
          const std::string& other = seeds[rng() % seeds.size()];
          if (!other.empty()) {
            const std::size_t from = rng() % other.size();
            x.insert(at, other.substr(from, 1 + rng() % 64));
          }
          break;
        }
        default:  // duplicate a line
          if (!x.empty()) {
            const std::size_t a = x.rfind('\n', at == 0 ? 0 : at - 1);
            const std::size_t b = x.find('\n', at);
            const std::size_t from = a == std::string::npos ? 0 : a + 1;
            x.insert(at, x.substr(from, (b == std::string::npos ? x.size() : b) - from));
          }
      }
    }
    if (!survives(x)) return 1;
  }
  std::printf("%zu seeds and %ld mutations: every input read or refused with an InputError\n",
              seeds.size(), runs);
  return 0;
}
