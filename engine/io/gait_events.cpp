#include "io/gait_events.hpp"

#include <algorithm>
#include <cmath>

#include "core/error.hpp"

namespace kneesim::io {

std::vector<FootContact> findFootContacts(const C3dFile& c3d, const FootContactOptions& options) {
  std::vector<FootContact> out;
  const int heel = c3d.markers.findMarker(options.heel_marker);
  if (heel < 0)
    throw InputError({c3d.path, 0, "POINT:LABELS"},
                     "expected a heel marker '" + options.heel_marker + "' to assign plate contacts to a foot, got none");
  const int spf = std::max(1, c3d.analog.samples_per_frame);
  const int frames = c3d.markers.getNumFrames();
  const double dt = c3d.analog.rate > 0 ? 1.0 / c3d.analog.rate : 0.0;
  const size_t min_samples = size_t(std::ceil(options.min_duration / std::max(dt, 1e-12) - 1e-9));
  for (int p = 0; p < int(c3d.plates.size()); ++p) {
    const PlateWrench w = calcPlateWrench(c3d, p, options.threshold);
    const auto& C = c3d.plates[size_t(p)].corners_m;
    // Runs [begin, end) of samples above the threshold, cleaned of spikes and short drops.
    std::vector<std::pair<size_t, size_t>> runs;
    for (size_t s = 0; s < w.force.size();) {
      if (!(w.force[s].z() > options.threshold)) {
        ++s;
        continue;
      }
      size_t e = s;
      while (e < w.force.size() && w.force[e].z() > options.threshold) ++e;
      if (!runs.empty() && s - runs.back().second < min_samples)
        runs.back().second = e;  // a short drop: the same contact
      else
        runs.emplace_back(s, e);
      s = e;
    }
    for (const auto& [begin, end] : runs) {
      if (end - begin < min_samples || begin == 0) continue;  // a spike, or loaded from the start
      const int f = std::min(int(begin) / spf, frames - 1);
      if (f < 0) break;
      const Eigen::Vector3d h = c3d.markers.getPosition(f, heel);
      // A missing heel marker (NaN) never counts as over the plate.
      if (!(h.x() >= C.row(0).minCoeff() && h.x() <= C.row(0).maxCoeff() && h.y() >= C.row(1).minCoeff() &&
            h.y() <= C.row(1).maxCoeff()))
        continue;
      FootContact c;
      c.plate = p;
      c.strike = c3d.analog.time[begin];
      if (end < w.force.size()) c.off = c3d.analog.time[end];
      out.push_back(c);
      break;  // the first contact of this foot on this plate
    }
  }
  std::sort(out.begin(), out.end(), [](const FootContact& a, const FootContact& b) { return a.strike < b.strike; });
  return out;
}

GaitCycle findGaitCycle(const std::vector<FootContact>& contacts) {
  GaitCycle g;
  if (contacts.empty()) return g;
  g.strike = contacts[0].strike;
  g.toe_off = contacts[0].off;
  if (contacts.size() >= 2) g.next_strike = contacts[1].strike;
  return g;
}

}  // namespace kneesim::io
