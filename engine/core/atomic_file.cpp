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

}  // namespace kneesim
