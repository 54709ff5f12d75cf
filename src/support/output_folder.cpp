#include "geardyn/output_folder.hpp"

#include <fmt/format.h>
#include <fmt/ranges.h>
#include <signal.h>

#include <algorithm>
#include <chrono>
#include <fstream>
#include <map>
#include <nlohmann/json.hpp>
#include <optional>
#include <random>

namespace geardyn {
namespace {

namespace fs = std::filesystem;

constexpr const char* kStagingPrefix = ".geardyn-staging-";
// Attempts at a staging name that is not taken (eight random hex digits each).
constexpr int kStagingAttempts = 16;

std::string random_tag() {
  std::random_device rd;
  return fmt::format("{:08x}", rd());
}

// What a set recorded of one of its files: enough to tell whether it is still ours.
struct Stamp {
  std::uintmax_t size = 0;
  std::int64_t mtime_ns = 0;
  bool operator==(const Stamp&) const = default;
};

std::optional<Stamp> stamp_of(const fs::path& p) {
  std::error_code ec;
  if (!fs::is_regular_file(fs::symlink_status(p, ec))) return std::nullopt;
  const std::uintmax_t size = fs::file_size(p, ec);
  if (ec) return std::nullopt;
  const auto t = fs::last_write_time(p, ec);
  if (ec) return std::nullopt;
  const auto since_1970 = std::chrono::file_clock::to_sys(t).time_since_epoch();
  return Stamp{size, std::chrono::duration_cast<std::chrono::nanoseconds>(since_1970).count()};
}

// The manifest: set name -> relative path -> stamp. An unreadable manifest is empty (it is
// ours; the next named commit writes it anew).
using Manifest = std::map<std::string, std::map<std::string, Stamp>>;

Manifest read_manifest(const fs::path& dir) {
  Manifest m;
  std::ifstream in(dir / kManifestName, std::ios::binary);
  if (!in) return m;
  try {
    const nlohmann::json j = nlohmann::json::parse(in);
    for (const auto& [set, files] : j.at("sets").items())
      for (const auto& [path, s] : files.items())
        m[set][path] =
            Stamp{s.at("size").get<std::uintmax_t>(), s.at("mtime_ns").get<std::int64_t>()};
  } catch (const std::exception&) {
    return {};
  }
  return m;
}

std::string manifest_text(const Manifest& m) {
  nlohmann::json sets = nlohmann::json::object();
  for (const auto& [set, files] : m) {
    nlohmann::json f = nlohmann::json::object();
    for (const auto& [path, s] : files) f[path] = {{"size", s.size}, {"mtime_ns", s.mtime_ns}};
    sets[set] = f;
  }
  return nlohmann::json{{"written_by",
                         "geardyn: the files each command wrote here, so that "
                         "its next run replaces them as a set; yours are never "
                         "touched"},
                        {"sets", sets}}
             .dump(1) +
         "\n";
}

// Holds SIGINT and SIGTERM in this thread while alive; a held signal acts when released.
class HeldSignals {
 public:
  HeldSignals() {
    sigset_t s;
    sigemptyset(&s);
    sigaddset(&s, SIGINT);
    sigaddset(&s, SIGTERM);
    pthread_sigmask(SIG_BLOCK, &s, &old_);
  }
  ~HeldSignals() { pthread_sigmask(SIG_SETMASK, &old_, nullptr); }
  HeldSignals(const HeldSignals&) = delete;
  HeldSignals& operator=(const HeldSignals&) = delete;

 private:
  sigset_t old_;
};

// The files of `relative` that are in `dir` but not as a set of `manifest` recorded them: the
// user's, or changed by the user since geardyn wrote them (a symbolic link is never ours).
std::vector<std::string> foreign_in(const fs::path& dir, const Manifest& manifest,
                                    const std::vector<std::string>& relative) {
  std::vector<std::string> foreign;
  std::error_code ec;
  for (const std::string& f : relative) {
    if (!fs::exists(fs::symlink_status(dir / f, ec))) continue;
    const std::optional<Stamp> now = stamp_of(dir / f);
    const bool ours = now && std::any_of(manifest.begin(), manifest.end(), [&](const auto& set) {
                        const auto it = set.second.find(f);
                        return it != set.second.end() && it->second == *now;
                      });
    if (!ours) foreign.push_back(f);
  }
  return foreign;
}

std::string foreign_message(const std::vector<std::string>& foreign) {
  return fmt::format(
      "{} not written by geardyn here, or changed since it was ({}): geardyn never replaces a "
      "file it did not write, so nothing was written and the folder is as it was; move {} away, "
      "or write to another folder",
      foreign.size() == 1 ? "the file exists and was" : "files of this name exist and were",
      fmt::join(foreign, ", "), foreign.size() == 1 ? "it" : "them");
}

}  // namespace

std::vector<std::string> foreign_files(const fs::path& dir,
                                       const std::vector<std::string>& relative) {
  return foreign_in(dir, read_manifest(dir), relative);
}

OutputSet::OutputSet(const fs::path& dir, std::string name) : name_(std::move(name)) {
  std::error_code ec;
  dir_ = fs::absolute(dir, ec);
  if (ec) dir_ = dir;
  // The missing folders, outermost first, so that an abandoned set removes what it made.
  std::vector<fs::path> missing;
  for (fs::path p = dir_; !p.empty() && !fs::exists(fs::symlink_status(p, ec));
       p = p.parent_path()) {
    missing.push_back(p);
    if (p == p.parent_path()) break;
  }
  std::reverse(missing.begin(), missing.end());
  for (const fs::path& p : missing) {
    if (!fs::create_directory(p, ec) || ec) {
      abandon();
      throw std::runtime_error(
          fmt::format("{}: cannot create the output folder: {}", p.string(), ec.message()));
    }
    created_.push_back(p);
  }
  if (!fs::is_directory(dir_, ec)) {
    abandon();
    throw std::runtime_error(fmt::format("{}: the output folder is not a folder", dir_.string()));
  }
  for (int attempt = 0; attempt < kStagingAttempts && staging_.empty(); ++attempt) {
    const fs::path candidate = dir_ / (kStagingPrefix + random_tag());
    if (fs::create_directory(candidate, ec) && !ec)
      staging_ = candidate;
    else if (ec)
      break;
  }
  if (staging_.empty()) {
    abandon();
    throw std::runtime_error(fmt::format("{}: cannot write in the output folder: {}", dir_.string(),
                                         ec ? ec.message() : "no free name"));
  }
}

OutputSet::~OutputSet() {
  if (!done_) abandon();
}

void OutputSet::abandon() noexcept {
  std::error_code ignored;
  if (!staging_.empty()) fs::remove_all(staging_, ignored);
  // Innermost first; a folder is removed only when empty (fs::remove refuses otherwise).
  for (auto it = created_.rbegin(); it != created_.rend(); ++it) fs::remove(*it, ignored);
  done_ = true;
}

void OutputSet::write(const std::string& relative, const std::string& text) {
  write(relative, [&text](std::ostream& out) { out << text; });
}

void OutputSet::write(const std::string& relative, const FileWriter& writer) {
  const fs::path p = staging_ / relative;
  std::error_code ec;
  fs::create_directories(p.parent_path(), ec);
  std::ofstream out(p, std::ios::binary | std::ios::trunc);
  if (out) writer(out);
  out.close();
  if (!out || ec)
    throw std::runtime_error(fmt::format("{}: cannot write", (dir_ / relative).string()));
}

std::vector<std::string> OutputSet::commit(const RenameFunction& rename) {
  const RenameFunction move = rename
                                  ? rename
                                  : RenameFunction([](const fs::path& a, const fs::path& b,
                                                      std::error_code& e) { fs::rename(a, b, e); });
  std::error_code ec;
  // The set's files, by their place relative to the folder.
  std::vector<fs::path> files;
  for (auto it = fs::recursive_directory_iterator(staging_, ec);
       !ec && it != fs::recursive_directory_iterator(); it.increment(ec))
    if (it->is_regular_file()) files.push_back(fs::relative(it->path(), staging_));
  if (ec) {
    abandon();
    throw std::runtime_error(
        fmt::format("{}: cannot list the files written: {}", staging_.string(), ec.message()));
  }
  std::sort(files.begin(), files.end());
  const auto fail = [&](const fs::path& p, const std::string& why) {
    abandon();
    throw std::runtime_error(fmt::format("{}: cannot write: {}", p.string(), why));
  };
  // Every target checked before anything moves: a folder (or anything else that is not a
  // file) of the user's under one of our names is never replaced, nor, for a named set, a file
  // that no set of the manifest records as geardyn left it (foreign_files).
  for (const fs::path& f : files) {
    const auto s = fs::symlink_status(dir_ / f, ec);
    if (fs::exists(s) && !fs::is_regular_file(s) && !fs::is_symlink(s))
      fail(dir_ / f, "exists and is not a regular file (it is left as it is)");
    for (fs::path up = f.parent_path(); !up.empty(); up = up.parent_path()) {
      const auto u = fs::status(dir_ / up, ec);
      if (fs::exists(u) && !fs::is_directory(u)) fail(dir_ / up, "exists and is not a folder");
    }
  }
  Manifest manifest;
  if (!name_.empty()) {
    manifest = read_manifest(dir_);
    std::vector<std::string> relative;
    relative.reserve(files.size());
    for (const fs::path& f : files) relative.push_back(f.generic_string());
    const std::vector<std::string> foreign = foreign_in(dir_, manifest, relative);
    if (!foreign.empty()) fail(dir_ / foreign.front(), foreign_message(foreign));
  }

  // The previous set of this name: its files that this one does not write again go with it,
  // when still as geardyn left them.
  std::vector<fs::path> stale;
  std::vector<std::string> kept;
  if (!name_.empty()) {
    for (const auto& [path, recorded] : manifest[name_]) {
      if (std::binary_search(files.begin(), files.end(), fs::path(path))) continue;
      const std::optional<Stamp> now = stamp_of(dir_ / path);
      if (!now) continue;
      if (*now == recorded)
        stale.push_back(path);
      else
        kept.push_back(path);
    }
    auto& mine = manifest[name_];
    mine.clear();
    for (const fs::path& f : files)
      if (const std::optional<Stamp> s = stamp_of(staging_ / f)) mine[f.generic_string()] = *s;
    // Another set's file that this one replaces is this set's now; sets whose files are all
    // gone are forgotten.
    for (auto it = manifest.begin(); it != manifest.end();) {
      if (it->first == name_) {
        ++it;
        continue;
      }
      std::erase_if(it->second, [&](const auto& e) {
        return !fs::exists(dir_ / e.first) || mine.count(e.first) > 0;
      });
      if (it->second.empty())
        it = manifest.erase(it);
      else
        ++it;
    }
    std::ofstream out(staging_ / kManifestName, std::ios::binary | std::ios::trunc);
    out << manifest_text(manifest);
    out.close();
    if (!out) fail(dir_ / kManifestName, "cannot write the manifest");
    files.emplace_back(kManifestName);
  }

  // Into place, each by one rename; what is replaced or removed is set aside (inside the staging
  // folder) until all are in.
  const HeldSignals held;
  const fs::path aside_dir = staging_ / (".aside-" + random_tag());
  fs::create_directory(aside_dir, ec);
  if (ec) fail(aside_dir, ec.message());
  std::vector<fs::path> placed, created_here;
  std::vector<std::pair<fs::path, fs::path>> set_aside;  // (from, to)
  const auto roll_back = [&](const fs::path& failed, const std::error_code& why) {
    std::error_code ignored;
    for (const fs::path& p : placed) fs::remove(p, ignored);
    for (auto it = set_aside.rbegin(); it != set_aside.rend(); ++it)
      fs::rename(it->second, it->first, ignored);
    for (auto it = created_here.rbegin(); it != created_here.rend(); ++it) fs::remove(*it, ignored);
    fail(failed, why.message());
  };
  std::size_t aside_count = 0;
  const auto put_aside = [&](const fs::path& target) {
    const fs::path to = aside_dir / std::to_string(aside_count++);
    move(target, to, ec);
    if (ec) roll_back(target, ec);
    set_aside.emplace_back(target, to);
  };
  for (const fs::path& f : files) {
    const fs::path target = dir_ / f;
    // Missing folders on the way, outermost first.
    std::vector<fs::path> up;
    for (fs::path p = target.parent_path(); p != dir_ && !fs::exists(p, ec); p = p.parent_path())
      up.push_back(p);
    for (auto it = up.rbegin(); it != up.rend(); ++it) {
      fs::create_directory(*it, ec);
      if (ec) roll_back(*it, ec);
      created_here.push_back(*it);
    }
    if (fs::exists(fs::symlink_status(target, ec))) put_aside(target);
    move(staging_ / f, target, ec);
    if (ec) roll_back(target, ec);
    placed.push_back(target);
  }
  for (const fs::path& s : stale) put_aside(dir_ / s);
  done_ = true;
  fs::remove_all(staging_, ec);  // the staging folder and what was set aside: ours
  return kept;
}

std::vector<std::string> write_set(const fs::path& dir, const std::string& name,
                                   const std::function<void(const fs::path&)>& stage,
                                   const RenameFunction& rename) {
  OutputSet set(dir, name);
  std::exception_ptr figure_failure;
  try {
    stage(set.staging());
  } catch (const FigureError&) {
    figure_failure = std::current_exception();
  }
  std::vector<std::string> kept = set.commit(rename);
  if (figure_failure) std::rethrow_exception(figure_failure);
  return kept;
}

void write_files_atomically(const fs::path& dir,
                            const std::vector<std::pair<std::string, std::string>>& files,
                            const RenameFunction& rename) {
  OutputSet set(dir);
  for (const auto& [name, text] : files) set.write(name, text);
  set.commit(rename);
}

void write_files_atomically(const fs::path& dir,
                            const std::vector<std::pair<std::string, FileWriter>>& files,
                            const RenameFunction& rename) {
  OutputSet set(dir);
  for (const auto& [name, writer] : files) set.write(name, writer);
  set.commit(rename);
}

}  // namespace geardyn
