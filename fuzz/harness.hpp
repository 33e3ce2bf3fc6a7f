#pragma once
// What every fuzz target shares: the input written to a file (the readers take paths, as users
// give them), the reader run on it, and the verdict. A one-line InputError is the answer expected
// of a reader to a bad file; anything else it throws (InternalError, std::bad_alloc,
// std::out_of_range, ...) or a multi-line InputError is a finding, reported by aborting so that
// libFuzzer saves the input. Crashes, leaks, undefined behaviour and allocations beyond
// -malloc_limit_mb are findings of the sanitizers and of libFuzzer themselves.

#include <cstddef>
#include <cstdint>
#include <functional>
#include <string>

namespace kneesim::fuzz {

/// The path of this process's input file with extension @p ext (".c3d", ".xml", ...), in a folder
/// of its own under the temporary folder (created once, removed at exit).
const std::string& inputPath(const std::string& ext);

/// Writes @p data to inputPath(ext) and returns that path.
const std::string& writeInput(const uint8_t* data, size_t size, const std::string& ext);

/// Runs @p read (which reads the file it is given); returns normally on success or on a one-line
/// InputError, aborts on anything else.
void expectInputErrorOnly(const std::function<void()>& read);

/// writeInput + expectInputErrorOnly(read(path)): the body of most targets.
int runReader(const uint8_t* data, size_t size, const std::string& ext,
              const std::function<void(const std::string& path)>& read);

}  // namespace kneesim::fuzz
