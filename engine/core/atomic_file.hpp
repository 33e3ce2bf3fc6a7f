#pragma once
// Output files are written to a temporary file beside the target and renamed into place on
// commit, so a run that fails half-way never leaves a half-written result behind.

#include <fstream>
#include <functional>
#include <string>

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

/// Writes a whole file with @p writer and commits it atomically.
void writeFileAtomically(const std::string& path, const std::function<void(std::ostream&)>& writer,
                         bool binary = false);

}  // namespace kneesim
