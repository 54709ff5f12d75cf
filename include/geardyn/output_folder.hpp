// geardyn: writing into an output folder that the user shares with us.
//
// The one mechanism behind every file geardyn writes (the command line, the library's writers,
// the Python package). Its contract:
//
// - Only the files a set names are created or replaced. Nothing else in the folder is touched:
//   the user's own files and folders, and the files of another command, stay as they are.
// - The files of a set are written into a private staging folder inside the output folder
//   (`.geardyn-staging-XXXXXXXX`, so that moving a file into place is a rename on the same file
//   system), then moved into place together by commit(): each file replaced atomically, the
//   files it replaces set aside until every one is in. On any failure the files already placed
//   are removed, those set aside restored, and the folders the set created removed: the folder
//   is as it was. SIGINT and SIGTERM are held while files move, so that Ctrl-C cannot leave half
//   a set (the signal is acted on once the set is in place).
// - A named set (a command: "run", "sweep", "reproduce park2010") records its files, with their
//   size and modification time, in the folder's manifest `.geardyn-files.json`. At its next
//   commit, the files of its previous set that it does not write again are removed with it
//   (replaced as a set), but only those still as geardyn left them: a file the user changed since
//   is kept, and named in what commit() returns. An unnamed set records nothing.
// - A named set never replaces a file that geardyn did not write: a file under one of its names
//   that no set of the manifest records with its present size and modification time (the
//   user's own, one the user changed since, a symbolic link) stops the commit before anything
//   moves, naming the files; the folder is as it was. An unnamed set keeps no record and
//   replaces its names (the library's writers into a named set's staging folder).
// - The output folder may be the current folder or the user's home; it and any missing parents
//   are created when the set is started, and removed again when it is abandoned.
#pragma once

#include <filesystem>
#include <functional>
#include <ostream>
#include <stdexcept>
#include <string>
#include <system_error>
#include <utility>
#include <vector>

namespace geardyn {

// How a file is moved into place (std::filesystem::rename; a test may make it fail).
using RenameFunction = std::function<void(const std::filesystem::path& from,
                                          const std::filesystem::path& to, std::error_code& ec)>;

// A file written by a function into its stream (a large file is streamed, never held whole).
using FileWriter = std::function<void(std::ostream&)>;

// A figure could not be drawn (gnuplot is missing or failed; the message says which and what it
// printed). The data files of its set are still written (write_set).
class FigureError : public std::runtime_error {
 public:
  using std::runtime_error::runtime_error;
};

// The name of the manifest a named set keeps in its output folder.
inline constexpr const char* kManifestName = ".geardyn-files.json";

class OutputSet {
 public:
  // Starts a set for `dir`: creates `dir` (and its missing parents) and the staging folder.
  // `name` empty: an unnamed set (no manifest). Throws std::runtime_error naming the path when
  // the folder cannot be created or written.
  explicit OutputSet(const std::filesystem::path& dir, std::string name = {});
  // Abandoned without commit(): the staging folder and the folders the set created are removed.
  ~OutputSet();
  OutputSet(const OutputSet&) = delete;
  OutputSet& operator=(const OutputSet&) = delete;

  const std::filesystem::path& dir() const { return dir_; }
  // Where the set's files are written, under their names relative to dir(); a writer may create
  // sub-folders here (reproduce writes cases/<id>/...).
  const std::filesystem::path& staging() const { return staging_; }

  // Writes staging()/relative. Throws std::runtime_error naming the final path on failure.
  void write(const std::string& relative, const std::string& text);
  void write(const std::string& relative, const FileWriter& writer);

  // Moves every file of staging() into place as described above. Returns the files of the
  // set's previous commit that it kept because they changed since (relative paths). Throws
  // std::runtime_error naming the path on failure, with the folder as it was.
  std::vector<std::string> commit(const RenameFunction& rename = {});

 private:
  void abandon() noexcept;

  std::filesystem::path dir_, staging_;
  std::string name_;
  std::vector<std::filesystem::path> created_;  // folders this set created, outermost first
  bool done_ = false;
};

// Writes a set into `dir`: `stage` writes its files into the staging folder it is given, and the
// set is committed. When `stage` throws, nothing is put in place, except for a FigureError
// (figures.hpp): the data files are committed, without the figure that failed, and the error is
// rethrown (the command line exits 3). Returns what OutputSet::commit() returns.
std::vector<std::string> write_set(const std::filesystem::path& dir, const std::string& name,
                                   const std::function<void(const std::filesystem::path&)>& stage,
                                   const RenameFunction& rename = {});

// The files among `relative` (paths relative to `dir`) that are in `dir` and that a named set
// would refuse to replace (above): so that a command can say so before its work.
std::vector<std::string> foreign_files(const std::filesystem::path& dir,
                                       const std::vector<std::string>& relative);

// Writes the named files into `dir` as an unnamed set.
void write_files_atomically(const std::filesystem::path& dir,
                            const std::vector<std::pair<std::string, std::string>>& files,
                            const RenameFunction& rename = {});
void write_files_atomically(const std::filesystem::path& dir,
                            const std::vector<std::pair<std::string, FileWriter>>& files,
                            const RenameFunction& rename = {});

}  // namespace geardyn
