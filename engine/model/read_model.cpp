// Reads a model file with the reader its extension names.
#include "model/read_model.hpp"

#include <filesystem>

#include "core/error.hpp"
#include "core/strings.hpp"
#include "model/osim_reader.hpp"
#include "model/urdf.hpp"

namespace kneesim::model {

ModelPtr readModel(const std::string& path) {
  if (!std::filesystem::is_regular_file(path)) throw InputError({path, 0, ""}, "model file not found");
  return endsWith(toLower(path), ".urdf") ? readUrdf(path) : readOsim(path);
}

}  // namespace kneesim::model
