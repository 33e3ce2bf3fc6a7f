#include "io/marker_table.hpp"

#include <cmath>
#include <limits>

#include "core/error.hpp"
#include "core/strings.hpp"
#include "io/c3d.hpp"
#include "io/trc.hpp"

namespace kneesim::io {

bool MarkerTable::isMissing(int frame, int marker) const {
  const Eigen::Vector3d& p = getPosition(frame, marker);
  return std::isnan(p.x()) || std::isnan(p.y()) || std::isnan(p.z());
}

int MarkerTable::findMarker(const std::string& name) const {
  for (size_t i = 0; i < labels.size(); ++i)
    if (labels[i] == name) return int(i);
  int found = -1;
  for (size_t i = 0; i < labels.size(); ++i) {
    const std::string& l = labels[i];
    const size_t colon = l.rfind(':');
    if (colon != std::string::npos && l.compare(colon + 1, std::string::npos, name) == 0) {
      if (found >= 0) return -1;  // ambiguous between two subjects: make the caller name it fully
      found = int(i);
    }
  }
  return found;
}

std::vector<std::pair<std::string, int>> MarkerTable::calcGapCounts() const {
  std::vector<std::pair<std::string, int>> out;
  out.reserve(labels.size());
  for (int m = 0; m < getNumMarkers(); ++m) {
    int n = 0;
    for (int f = 0; f < getNumFrames(); ++f) n += isMissing(f, m) ? 1 : 0;
    out.emplace_back(labels[size_t(m)], n);
  }
  return out;
}

void MarkerTable::resize(int frames, int markers) {
  const double nan = std::numeric_limits<double>::quiet_NaN();
  labels.resize(size_t(markers));
  time.assign(size_t(frames), 0.0);
  frame_numbers.assign(size_t(frames), 0);
  positions.assign(size_t(frames) * size_t(markers), Eigen::Vector3d(nan, nan, nan));
}

MarkerTable readMarkerFile(const std::string& path) {
  const std::string low = toLower(path);
  if (endsWith(low, ".trc")) return readTrc(path);
  if (endsWith(low, ".c3d")) return readC3d(path).markers;
  throw InputError({path, 0, ""}, "unknown marker file type: expected a .trc or .c3d file");
}

}  // namespace kneesim::io
