// The output folder shared with the user (output_folder.hpp): only our files replaced, each set
// together, a failure leaving the folder as it was.
#include "geardyn/output_folder.hpp"

#include <gtest/gtest.h>
#include <unistd.h>

#include <csignal>
#include <filesystem>
#include <fstream>
#include <functional>
#include <map>
#include <sstream>

namespace geardyn {
namespace {

namespace fs = std::filesystem;

fs::path fresh_dir(const std::string& name) {
  const fs::path d = fs::temp_directory_path() /
                     ("geardyn_output_folder_" + name + "_" + std::to_string(getpid()));
  fs::remove_all(d);
  return d;
}

std::string slurp(const fs::path& p) {
  std::ifstream in(p, std::ios::binary);
  std::stringstream s;
  s << in.rdbuf();
  return s.str();
}

void put(const fs::path& p, const std::string& text) {
  fs::create_directories(p.parent_path());
  std::ofstream(p, std::ios::binary) << text;
}

// Everything under `dir`: relative path -> contents ("<dir>" for a folder).
std::map<std::string, std::string> snapshot(const fs::path& dir) {
  std::map<std::string, std::string> out;
  for (const auto& e : fs::recursive_directory_iterator(dir))
    out[fs::relative(e.path(), dir).generic_string()] =
        e.is_directory() ? std::string("<dir>") : slurp(e.path());
  return out;
}

// A folder the user works in: a file, a folder with a file, and a file under one of our names
// in a sub-folder we do not write.
fs::path users_folder(const std::string& name) {
  const fs::path d = fresh_dir(name);
  put(d / "thesis.tex", "draft");
  put(d / "src" / "a.c", "code");
  put(d / "notes" / "summary.json", "the user's own");
  return d;
}

TEST(OutputFolder, KeepsTheUsersFilesAndReplacesOnlyItsOwn) {
  const fs::path d = users_folder("keeps");
  write_set(d, "run", [](const fs::path& s) {
    put(s / "summary.json", "one");
    put(s / "cases" / "a" / "x.csv", "1");
  });
  write_set(d, "run", [](const fs::path& s) {
    put(s / "summary.json", "two");
    put(s / "cases" / "a" / "x.csv", "2");
  });
  const auto files = snapshot(d);
  EXPECT_EQ(files.at("thesis.tex"), "draft");
  EXPECT_EQ(files.at("src/a.c"), "code");
  EXPECT_EQ(files.at("notes/summary.json"), "the user's own");
  EXPECT_EQ(files.at("summary.json"), "two");
  EXPECT_EQ(files.at("cases/a/x.csv"), "2");
  // Nothing else: no staging folder, nothing set aside; the manifest alone is added.
  EXPECT_EQ(files.size(), 10U);  // 3 files, 2 folders of the user's; 3 files, 2 folders of ours
  EXPECT_TRUE(files.count(kManifestName));
}

TEST(OutputFolder, ASetReplacesItsEarlierFilesAsASetButKeepsOnesTheUserChanged) {
  const fs::path d = users_folder("as_a_set");
  write_set(d, "run", [](const fs::path& s) {
    put(s / "data.csv", "1");
    put(s / "figure.png", "png");
    put(s / "figure.svg", "svg");
  });
  put(d / "figure.svg", "edited by the user");  // changed since geardyn wrote it
  // A later run without figures: the earlier figure goes, the edited one stays and is named.
  const std::vector<std::string> kept =
      write_set(d, "run", [](const fs::path& s) { put(s / "data.csv", "2"); });
  EXPECT_EQ(kept, std::vector<std::string>{"figure.svg"});
  EXPECT_EQ(slurp(d / "data.csv"), "2");
  EXPECT_FALSE(fs::exists(d / "figure.png"));
  EXPECT_EQ(slurp(d / "figure.svg"), "edited by the user");
  // Another command's set is another set: a sweep does not remove the run's files.
  write_set(d, "sweep", [](const fs::path& s) { put(s / "sweep.csv", "s"); });
  write_set(d, "sweep", [](const fs::path& s) { put(s / "sweep.csv", "t"); });
  EXPECT_EQ(slurp(d / "data.csv"), "2");
  EXPECT_EQ(slurp(d / "thesis.tex"), "draft");
}

TEST(OutputFolder, AnUnnamedSetRemovesNothing) {
  const fs::path d = users_folder("unnamed");
  write_files_atomically(d, {{"a.txt", "a"}, {"b.txt", "b"}});
  write_files_atomically(d, {{"a.txt", "A"}});
  EXPECT_EQ(slurp(d / "b.txt"), "b");
  EXPECT_EQ(slurp(d / "a.txt"), "A");
  EXPECT_FALSE(fs::exists(d / kManifestName));
}

TEST(OutputFolder, AFailureAtAnyMoveLeavesTheFolderAsItWas) {
  // Each move of a commit fails in turn (as a full disk would make it): whatever had moved is
  // taken back, so the folder is what it was to the byte, the user's files, our earlier set and
  // the manifest included.
  const fs::path d = users_folder("fail_at_k");
  const auto first = [](const fs::path& s) {
    put(s / "summary.json", "old");
    put(s / "old_only.csv", "old");
    put(s / "cases" / "a" / "x.csv", "old");
  };
  write_set(d, "study", first);
  const auto before = snapshot(d);
  const auto second = [](const fs::path& s) {
    put(s / "summary.json", "new");
    put(s / "cases" / "a" / "x.csv", "new");
    put(s / "cases" / "b" / "y.csv", "new");
  };
  int failures = 0;
  for (int fail_at = 0;; ++fail_at) {
    int moves = 0;
    const RenameFunction failing = [&](const fs::path& from, const fs::path& to,
                                       std::error_code& ec) {
      if (moves++ == fail_at) {
        ec = std::make_error_code(std::errc::no_space_on_device);
        return;
      }
      fs::rename(from, to, ec);
    };
    try {
      write_set(d, "study", second, failing);
    } catch (const std::runtime_error& e) {
      ++failures;
      EXPECT_NE(std::string(e.what()).find("cannot write"), std::string::npos);
      EXPECT_EQ(snapshot(d), before) << "failing move " << fail_at;
      continue;
    }
    break;  // no move left to fail: the set went in
  }
  // x.csv, summary.json and the manifest (each set aside, then moved in), y.csv (moved in) and
  // old_only.csv (set aside): eight moves, each of which failed once.
  EXPECT_EQ(failures, 8);
  EXPECT_EQ(slurp(d / "cases" / "b" / "y.csv"), "new");
  EXPECT_FALSE(fs::exists(d / "old_only.csv"));
  EXPECT_EQ(slurp(d / "thesis.tex"), "draft");
}

TEST(OutputFolder, AUsersFolderUnderOneOfOurNamesIsNeverReplaced) {
  const fs::path d = users_folder("obstacle");
  fs::create_directories(d / "summary.json" / "inside");
  const auto before = snapshot(d);
  try {
    write_files_atomically(d, {{"a.txt", "a"}, {"summary.json", "s"}});
    FAIL() << "a folder was replaced";
  } catch (const std::runtime_error& e) {
    EXPECT_NE(std::string(e.what()).find("exists and is not a regular file"), std::string::npos)
        << e.what();
  }
  EXPECT_EQ(snapshot(d), before);
}

// The error of a commit refused for `name`, with the folder as `before`.
void expect_foreign_refused(const fs::path& d, const std::map<std::string, std::string>& before,
                            const std::function<void(const fs::path&)>& stage,
                            const std::string& name, const std::string& what) {
  try {
    write_set(d, "run", stage);
    ADD_FAILURE() << what << ": " << name << " was replaced";
  } catch (const std::runtime_error& e) {
    const std::string m = e.what();
    EXPECT_NE(m.find(name + ": cannot write: the file exists and was not written by geardyn"),
              std::string::npos)
        << what << ": " << m;
    EXPECT_NE(m.find("nothing was written"), std::string::npos) << what << ": " << m;
  }
  EXPECT_EQ(snapshot(d), before) << what;
}

TEST(OutputFolder, AFileGeardynDidNotWriteIsNeverReplaced) {
  const auto stage = [](const fs::path& s) {
    put(s / "summary.json", "ours");
    put(s / "data.csv", "1");
  };
  // The user's own file under one of our names: the set is refused before anything moves.
  fs::path d = users_folder("foreign");
  put(d / "summary.json", "the user's summary");
  EXPECT_EQ(foreign_files(d, {"summary.json", "data.csv", "thesis.tex"}),
            (std::vector<std::string>{"summary.json", "thesis.tex"}));
  expect_foreign_refused(d, snapshot(d), stage, "summary.json", "the user's file");
  // A file geardyn wrote and the user changed since is the user's now.
  fs::remove(d / "summary.json");
  write_set(d, "run", stage);
  EXPECT_TRUE(foreign_files(d, {"summary.json", "data.csv"}).empty());
  put(d / "summary.json", "edited by the user");
  expect_foreign_refused(d, snapshot(d), stage, "summary.json", "a file the user changed");
  // A symbolic link under one of our names is never ours, whatever it points to.
  fs::remove(d / "summary.json");
  fs::create_symlink(d / "thesis.tex", d / "summary.json");
  expect_foreign_refused(d, snapshot(d), stage, "summary.json", "a symbolic link");
  EXPECT_EQ(slurp(d / "thesis.tex"), "draft");
  fs::remove(d / "summary.json");
  // Another set's file is geardyn's: replaced, and this set's from then on, so that the first
  // set's next commit without it leaves it.
  write_set(d, "run", stage);
  write_set(d, "sweep", [](const fs::path& s) { put(s / "summary.json", "the sweep's"); });
  write_set(d, "run", [](const fs::path& s) { put(s / "data.csv", "2"); });
  EXPECT_EQ(slurp(d / "summary.json"), "the sweep's");
  EXPECT_EQ(slurp(d / "data.csv"), "2");
  EXPECT_EQ(slurp(d / "thesis.tex"), "draft");
  // An unnamed set keeps no record and replaces its names (a named set's staging writers).
  write_files_atomically(d, {{"thesis.tex", "replaced"}});
  EXPECT_EQ(slurp(d / "thesis.tex"), "replaced");
}

TEST(OutputFolder, TheFoldersASetMadeGoWhenItFails) {
  const fs::path root = fresh_dir("made");
  const fs::path d = root / "deep" / "out";
  fs::create_directories(root);
  EXPECT_THROW(write_set(d, "run",
                         [](const fs::path& s) {
                           put(s / "a.txt", "a");
                           throw std::runtime_error("the work failed");
                         }),
               std::runtime_error);
  EXPECT_TRUE(fs::is_empty(root));
}

TEST(OutputFolder, AFigureThatFailsStillLetsTheDataIn) {
  const fs::path d = users_folder("figure");
  EXPECT_THROW(write_set(d, "run",
                         [](const fs::path& s) {
                           put(s / "data.csv", "1");
                           throw FigureError("gnuplot failed");
                         }),
               FigureError);
  EXPECT_EQ(slurp(d / "data.csv"), "1");
}

TEST(OutputFolder, TheCurrentFolderIsAnOutputFolder) {
  const fs::path d = users_folder("dot");
  const fs::path was = fs::current_path();
  fs::current_path(d);
  write_set(".", "run", [](const fs::path& s) { put(s / "summary.json", "x"); });
  fs::current_path(was);
  EXPECT_EQ(slurp(d / "summary.json"), "x");
  EXPECT_EQ(slurp(d / "thesis.tex"), "draft");
}

volatile std::sig_atomic_t g_all_in_place = -1;
fs::path g_watched;
extern "C" void on_sigint(int) {
  g_all_in_place = fs::exists(g_watched / "a.txt") && fs::exists(g_watched / "b.txt") ? 1 : 0;
}

TEST(OutputFolder, CtrlCDuringTheMovesActsOnlyOnceTheSetIsIn) {
  const fs::path d = fresh_dir("sigint");
  g_watched = d;
  const auto previous = std::signal(SIGINT, on_sigint);
  int moves = 0;
  const RenameFunction interrupted = [&](const fs::path& from, const fs::path& to,
                                         std::error_code& ec) {
    if (moves++ == 0) std::raise(SIGINT);  // held: the set goes in first
    fs::rename(from, to, ec);
  };
  write_files_atomically(d, {{"a.txt", "a"}, {"b.txt", "b"}}, interrupted);
  std::signal(SIGINT, previous);
  EXPECT_EQ(g_all_in_place, 1);
}

}  // namespace
}  // namespace geardyn
