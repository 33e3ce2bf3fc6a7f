#pragma once
// std::filesystem's throwing forms report a user's bad path (a name longer than the system
// allows, a folder without permission) as std::filesystem_error, which reaches the command line as
// an "internal error". The run paths use these instead: a path that cannot be looked at does not
// exist, and a folder that cannot be made is the user's one-line error naming it.

#include <filesystem>
#include <string>
#include <system_error>

#include "core/error.hpp"

namespace kneesim {

/// Whether @p path exists; false when it cannot be looked at (never throws).
inline bool pathExists(const std::filesystem::path& path) noexcept {
  std::error_code ec;
  return std::filesystem::exists(path, ec);
}

/// Creates folder @p path and its missing parents; throws InputError naming it when it cannot.
inline void createFolder(const std::filesystem::path& path) {
  std::error_code ec;
  std::filesystem::create_directories(path, ec);
  if (ec || !std::filesystem::is_directory(path, ec))
    throw InputError({path.string(), 0, ""}, "cannot create folder: " + (ec ? ec.message() : std::string("not a folder")));
}

}  // namespace kneesim
