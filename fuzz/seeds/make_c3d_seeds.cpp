// Writes the C3D seeds of fuzz/corpus/c3d/: the first frames of two of JW's trials (data/), with
// their analog channels and force platforms, in each processor's encoding and in both point
// formats. The Grand Challenge files are hundreds of kilobytes; a seed of a few frames lets the
// fuzzer mutate the parameter section and the layout instead of copying data around.
//   make_c3d_seeds <data folder> <output folder>
#include <cstdio>
#include <string>

#include "io/c3d.hpp"

using namespace kneesim::io;

namespace {

C3dFile firstFrames(const C3dFile& in, int frames) {
  C3dFile out = in;
  const int np = in.markers.getNumMarkers();
  out.markers.time.resize(size_t(frames));
  out.markers.frame_numbers.resize(size_t(frames));
  out.markers.positions.resize(size_t(frames) * size_t(np));
  out.residuals.resize(out.markers.positions.size());
  const int spf = in.analog.samples_per_frame;
  out.analog.time.resize(size_t(frames) * size_t(spf));
  out.analog.data = in.analog.data.topRows(Eigen::Index(frames) * spf).eval();
  out.last_frame = out.first_frame + frames - 1;
  return out;
}

}  // namespace

int main(int argc, char** argv) {
  if (argc != 3) {
    std::fprintf(stderr, "usage: make_c3d_seeds <data folder> <output folder>\n");
    return 2;
  }
  const std::string data = argv[1], dir = argv[2];
  const C3dFile gait = firstFrames(readC3d(data + "/kgc4-jw/markers/jw_ngait_og3.c3d"), 3);
  const C3dFile stand = firstFrames(readC3d(data + "/kgc4-jw/markers/jw_1legstand1.c3d"), 2);
  writeC3d(dir + "/gait-intel-float.c3d", gait, {"Intel", true, 0.1, "mm"});
  writeC3d(dir + "/gait-dec-int.c3d", gait, {"DEC", false, 0.1, "mm"});
  writeC3d(dir + "/gait-mips-float-m.c3d", gait, {"MIPS", true, 0.1, "m"});
  writeC3d(dir + "/stand-intel-int-cm.c3d", stand, {"Intel", false, 0.1, "cm"});
  return 0;
}
