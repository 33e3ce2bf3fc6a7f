#include "core/atomic_file.hpp"

#include <unistd.h>

#include <cerrno>
#include <cstdio>
#include <cstring>
#include <filesystem>

#include "core/error.hpp"

namespace kneesim {

AtomicFile::AtomicFile(std::string path, bool binary) : path_(std::move(path)) {
  namespace fs = std::filesystem;
  const fs::path target(path_);
  std::error_code ec;
  if (target.has_parent_path()) fs::create_directories(target.parent_path(), ec);
  tmp_ = (target.has_parent_path() ? target.parent_path() / "" : fs::path()).string() + "." +
         target.filename().string() + ".tmp" + std::to_string(::getpid());
  out_.open(tmp_, binary ? std::ios::out | std::ios::binary | std::ios::trunc : std::ios::out | std::ios::trunc);
  if (!out_)
    throw InputError({path_, 0, ""}, std::string("cannot create output file: ") + std::strerror(errno));
  out_.precision(17);
}

AtomicFile::~AtomicFile() {
  if (!committed_) {
    out_.close();
    std::remove(tmp_.c_str());
  }
}

void AtomicFile::commit() {
  out_.flush();
  const bool ok = static_cast<bool>(out_);
  out_.close();
  if (!ok) throw InputError({path_, 0, ""}, "write failed (disk full?)");
  if (std::rename(tmp_.c_str(), path_.c_str()) != 0)
    throw InputError({path_, 0, ""}, std::string("cannot rename output into place: ") + std::strerror(errno));
  committed_ = true;
}

void writeFileAtomically(const std::string& path, const std::function<void(std::ostream&)>& writer, bool binary) {
  AtomicFile f(path, binary);
  writer(f.stream());
  f.commit();
}

namespace {
namespace fs = std::filesystem;

std::string siblingName(const std::string& path, const std::string& suffix) {
  const fs::path target(path);
  return (target.has_parent_path() ? target.parent_path() / "" : fs::path()).string() + "." +
         target.filename().string() + suffix + std::to_string(::getpid());
}
}  // namespace

struct AtomicFileSet::Entry {
  std::string path, tmp, backup;
  std::ofstream out;
  bool had_old = false, placed = false;
};

AtomicFileSet::AtomicFileSet() = default;

AtomicFileSet::~AtomicFileSet() {
  if (committed_) return;
  for (auto& e : entries_) {
    e->out.close();
    std::remove(e->tmp.c_str());
  }
}

std::ostream& AtomicFileSet::add(const std::string& path, bool binary) {
  KNEESIM_CHECK(!committed_, "AtomicFileSet: add() after commit()");
  for (const auto& e : entries_)
    if (fs::path(e->path).lexically_normal() == fs::path(path).lexically_normal())
      throw InputError({path, 0, ""}, "two outputs of the run would be written to the same file");
  auto e = std::make_unique<Entry>();
  e->path = path;
  const fs::path target(path);
  std::error_code ec;
  if (target.has_parent_path()) fs::create_directories(target.parent_path(), ec);
  e->tmp = siblingName(path, ".tmp");
  e->backup = siblingName(path, ".old");
  e->out.open(e->tmp, binary ? std::ios::out | std::ios::binary | std::ios::trunc : std::ios::out | std::ios::trunc);
  if (!e->out)
    throw InputError({path, 0, ""}, std::string("cannot create output file: ") + std::strerror(errno));
  e->out.precision(17);
  entries_.push_back(std::move(e));
  return entries_.back()->out;
}

void AtomicFileSet::addContents(const std::string& path, const std::string& contents, bool binary) {
  add(path, binary).write(contents.data(), std::streamsize(contents.size()));
}

std::vector<std::string> AtomicFileSet::getPaths() const {
  std::vector<std::string> paths;
  for (const auto& e : entries_) paths.push_back(e->path);
  return paths;
}

void AtomicFileSet::commit() {
  KNEESIM_CHECK(!committed_, "AtomicFileSet: commit() twice");
  for (auto& e : entries_) {
    e->out.flush();
    const bool ok = static_cast<bool>(e->out);
    e->out.close();
    if (!ok) throw InputError({e->path, 0, ""}, "write failed (disk full?)");
  }
  // Move earlier versions aside, then place the new files; undo everything on the first failure.
  auto rollback = [&]() {
    for (auto& e : entries_) {
      if (e->placed) std::remove(e->path.c_str());
      if (e->had_old) std::rename(e->backup.c_str(), e->path.c_str());
      std::remove(e->tmp.c_str());
    }
  };
  for (auto& e : entries_) {
    std::error_code ec;
    // Existing regular files are moved aside; anything else at the target (a folder) is left
    // alone and makes the rename below fail.
    const fs::file_status st = fs::symlink_status(e->path, ec);
    if (fs::is_regular_file(st) || fs::is_symlink(st)) {
      if (std::rename(e->path.c_str(), e->backup.c_str()) != 0) {
        const std::string why = std::strerror(errno);
        rollback();
        throw InputError({e->path, 0, ""}, "cannot replace the existing file: " + why);
      }
      e->had_old = true;
    }
    if (std::rename(e->tmp.c_str(), e->path.c_str()) != 0) {
      const std::string why = std::strerror(errno);
      rollback();
      throw InputError({e->path, 0, ""}, "cannot rename output into place: " + why);
    }
    e->placed = true;
  }
  for (auto& e : entries_)
    if (e->had_old) std::remove(e->backup.c_str());
  committed_ = true;
}

}  // namespace kneesim
