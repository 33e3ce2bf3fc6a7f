#pragma once
// Output files are written to a temporary file beside the target and renamed into place on
// commit, so a run that fails half-way never leaves a half-written result behind.

#include <fstream>
#include <functional>
#include <memory>
#include <string>
#include <vector>

namespace kneesim {

/// A file being written. Write to stream(); call commit() to publish it under its final name.
/// If the object is destroyed without commit() (an exception, an early return) the temporary
/// file is removed and any existing file at the target path is left untouched.
class AtomicFile {
 public:
  /// Opens a temporary file next to @p path. Creates missing parent folders.
  /// Throws InputError naming @p path if it cannot be created.
  explicit AtomicFile(std::string path, bool binary = false);
  ~AtomicFile();
  AtomicFile(const AtomicFile&) = delete;
  AtomicFile& operator=(const AtomicFile&) = delete;

  /// The stream to write to.
  std::ofstream& stream() { return out_; }
  /// Flushes, checks for write errors and renames the temporary file onto the target path.
  void commit();
  /// The final path.
  const std::string& getPath() const { return path_; }

 private:
  std::string path_;
  std::string tmp_;
  std::ofstream out_;
  bool committed_ = false;
};

/// Several output files that appear together or not at all. Each file is staged to a temporary
/// file beside its target; commit() renames them all into place. If one rename fails, the files
/// already renamed are rolled back (an earlier version of a target is restored, a new target
/// removed) and InputError is thrown, so a run's outputs never mix with a failed run's. A set
/// destroyed before commit() removes its temporaries and touches no target.
class AtomicFileSet {
 public:
  AtomicFileSet();
  ~AtomicFileSet();
  AtomicFileSet(const AtomicFileSet&) = delete;
  AtomicFileSet& operator=(const AtomicFileSet&) = delete;

  /// Stages @p path (creating missing parent folders) and returns the stream to write it to.
  /// Throws InputError naming @p path if it is already staged or cannot be created.
  std::ostream& add(const std::string& path, bool binary = false);
  /// Stages @p path with the given contents.
  void addContents(const std::string& path, const std::string& contents, bool binary = false);
  /// Checks every stream for write errors, then renames all staged files into place.
  void commit();
  /// Final paths of the staged files, in staging order.
  std::vector<std::string> getPaths() const;

 private:
  struct Entry;
  std::vector<std::unique_ptr<Entry>> entries_;
  bool committed_ = false;
};

/// Writes a whole file with @p writer and commits it atomically.
void writeFileAtomically(const std::string& path, const std::function<void(std::ostream&)>& writer,
                         bool binary = false);

}  // namespace kneesim
