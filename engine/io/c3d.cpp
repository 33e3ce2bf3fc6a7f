// Reading C3D files: the header, the layout of the frames, the point data and the analog data
// (the parameter section is c3d_parameters.cpp's job, the force platforms c3d_plates.cpp's).

#include "io/c3d.hpp"

#include <cerrno>
#include <cmath>
#include <cstring>
#include <fstream>

#include "core/error.hpp"
#include "core/strings.hpp"
#include "io/c3d_detail.hpp"
#include "io/text_fields.hpp"

namespace kneesim::io {

namespace {

using namespace detail;

constexpr double kNaN = std::numeric_limits<double>::quiet_NaN();
constexpr long kMaxFrames = 100000000L;

// Where the frames are and how they are stored.
struct Layout {
  long first = 1, frames = 0;  // first frame number (1-based) and frame count
  int npoints = 0, nch = 0, spf = 0;  // points, analog channels, analog samples per frame
  bool is_float = false;
  double abs_scale = 0, rate = 0, to_m = 0;  // |POINT:SCALE|, frame rate (Hz), POINT:UNITS to metres
  size_t word = 2, frame_bytes = 0, dstart = 0;  // bytes per value and per frame, first data byte
};

[[noreturn]] void fail(const std::string& path, const std::string& element, const std::string& msg) {
  throw InputError({path, 0, element}, msg);
}

std::vector<uint8_t> readAllBytes(const std::string& path) {
  std::ifstream in(path, std::ios::binary | std::ios::ate);
  if (!in) throw InputError({path, 0, ""}, std::string("cannot open C3D file: ") + std::strerror(errno));
  const std::streamoff size = in.tellg();
  std::vector<uint8_t> bytes(size > 0 ? size_t(size) : 0);
  in.seekg(0);
  if (!bytes.empty() && !in.read(reinterpret_cast<char*>(bytes.data()), std::streamsize(bytes.size())))
    throw InputError({path, 0, ""}, "cannot read C3D file");
  return bytes;
}

// Checks the header block and the processor type, decodes the header into out.header; returns the
// processor's codec.
Codec readHeader(const std::vector<uint8_t>& b, C3dFile& out) {
  const std::string& path = out.path;
  auto fail = [&](const std::string& element, const std::string& msg) { io::fail(path, element, msg); };
  if (b.size() < size_t(kC3dBlock))
    fail("header", "expected a C3D header of 512 bytes, the file has " + std::to_string(b.size()) + " bytes");
  if (b[1] != kC3dKey)
    fail("header", "expected the C3D key byte 0x50 at byte 2, got 0x" +
                       std::string(1, "0123456789abcdef"[b[1] >> 4]) + std::string(1, "0123456789abcdef"[b[1] & 15]) +
                       " (not a C3D file?)");
  out.header.parameter_block = b[0];
  if (b[0] == 0) fail("header", "expected a parameter section block number of 1 or more, got 0");
  const size_t pstart = size_t(b[0] - 1) * kC3dBlock;
  if (pstart + 4 > b.size())
    fail("header", "parameter section pointer (block " + std::to_string(b[0]) + ", byte " + std::to_string(pstart) +
                       ") points past the end of the file (" + std::to_string(b.size()) + " bytes)");
  const int proc_byte = b[pstart + 3];
  if (proc_byte != 84 && proc_byte != 85 && proc_byte != 86)
    fail("parameters", "expected processor type 84 (Intel), 85 (DEC) or 86 (MIPS) in the parameter header, got " +
                           std::to_string(proc_byte));
  const Proc proc = Proc(proc_byte);
  out.processor = procName(proc);

  Codec c;
  c.proc = proc;
  C3dHeader& h = out.header;
  h.num_points = c.u16(&b[2]);
  h.analog_per_frame = c.u16(&b[4]);
  h.first_frame = c.u16(&b[6]);
  h.last_frame = c.u16(&b[8]);
  h.max_interpolation_gap = c.u16(&b[10]);
  h.scale = c.f32(&b[12]);
  h.data_start = c.u16(&b[16]);
  h.analog_samples_per_frame = c.u16(&b[18]);
  h.frame_rate = c.f32(&b[20]);
  return c;
}

// The frame range: the header holds 16-bit numbers; TRIAL fields and POINT:FRAMES hold longer trials.
void findFrames(C3dFile& out, Layout& l) {
  auto fail = [&](const std::string& element, const std::string& msg) { io::fail(out.path, element, msg); };
  const C3dHeader& h = out.header;
  long first = h.first_frame, last = h.last_frame;
  const bool have_trial = trialField(out, "ACTUAL_START_FIELD", first) && trialField(out, "ACTUAL_END_FIELD", last);
  if (!have_trial) {
    first = h.first_frame;
    last = h.last_frame;
  }
  long frames = last - first + 1;
  const C3dParameter* pf = out.findParameter("POINT", "FRAMES");
  if (!have_trial && pf && !pf->values.empty()) {
    const long n = toWhole(out, pf->getUnsigned(0), 0, kMaxFrames, "POINT:FRAMES");
    if (n > frames) frames = n;  // header last frame saturated at 65535
  }
  if (frames < 0) frames = 0;
  if (frames > kMaxFrames)
    fail("POINT:FRAMES", "expected at most 100000000 frames, got " + std::to_string(frames) + " (corrupt header?)");
  if (first < 1 && frames > 0) first = 1;
  if (first + frames - 1 > long(std::numeric_limits<int>::max()))
    fail("TRIAL:ACTUAL_START_FIELD", "expected frame numbers up to " + std::to_string(std::numeric_limits<int>::max()) +
                                         ", got frames " + std::to_string(first) + ".." + std::to_string(first + frames - 1));
  out.first_frame = int(first);
  out.last_frame = int(first + frames - 1);
  l.first = first;
  l.frames = frames;
}

// Scale, rate, analog channels, data start and units; checks that the file holds every frame.
void findLayout(const std::vector<uint8_t>& b, const C3dFile& out, Layout& l) {
  auto fail = [&](const std::string& element, const std::string& msg) { io::fail(out.path, element, msg); };
  const C3dHeader& h = out.header;
  const long frames = l.frames;
  l.npoints = h.num_points;
  double scale = firstValue(out, "POINT", "SCALE", h.scale);
  if (scale == 0) scale = h.scale;
  l.is_float = scale < 0;
  l.abs_scale = std::fabs(scale);
  double rate = firstValue(out, "POINT", "RATE", h.frame_rate);
  if (!(rate > 0)) rate = h.frame_rate;
  if (frames > 0 && !(rate > 0))
    fail("POINT:RATE", "expected a positive frame rate, got " + std::to_string(rate));

  int nch = int(firstWhole(out, "ANALOG", "USED", -1, 0, 65535, true));
  int spf = h.analog_samples_per_frame;
  if (nch < 0) nch = (spf > 0) ? h.analog_per_frame / spf : 0;
  if (h.analog_per_frame == 0) {
    nch = 0;
    spf = 0;
  } else if (nch > 0) {
    if (h.analog_per_frame % nch != 0)
      fail("ANALOG:USED", "expected the header's " + std::to_string(h.analog_per_frame) +
                              " analog values per frame to be a multiple of ANALOG:USED = " + std::to_string(nch));
    spf = h.analog_per_frame / nch;
  } else {
    fail("ANALOG:USED", "expected analog channels for the header's " + std::to_string(h.analog_per_frame) +
                            " analog values per frame, got ANALOG:USED = 0");
  }

  int data_start = h.data_start;
  if (data_start == 0) data_start = int(firstWhole(out, "POINT", "DATA_START", 0, 0, 65535, true));
  if (data_start < 1) fail("header", "expected a data start block of 1 or more, got " + std::to_string(data_start));
  l.word = l.is_float ? 4 : 2;
  l.frame_bytes = (size_t(l.npoints) * 4 + size_t(h.analog_per_frame)) * l.word;
  l.dstart = size_t(data_start - 1) * kC3dBlock;
  const size_t frame_bytes = l.frame_bytes, dstart = l.dstart;
  // Frames without point or analog data take no bytes, but each costs a time and a frame number:
  // a corrupt frame count must not allocate gigabytes.
  if (frame_bytes == 0 && size_t(frames) > b.size())
    fail("POINT:FRAMES", "expected at most " + std::to_string(b.size()) + " frames in a file of " +
                             std::to_string(b.size()) + " bytes without point or analog data, got " +
                             std::to_string(frames));
  const size_t needed = dstart + size_t(frames) * frame_bytes;
  if (needed > b.size()) {
    const size_t complete = b.size() > dstart && frame_bytes > 0 ? (b.size() - dstart) / frame_bytes : 0;
    fail("data", "truncated C3D data: expected " + std::to_string(frames) + " frames x " + std::to_string(frame_bytes) +
                     " bytes from byte " + std::to_string(dstart) + " (" + std::to_string(needed) +
                     " bytes in all), the file has " + std::to_string(b.size()) + " bytes (" + std::to_string(complete) +
                     " complete frames)");
  }

  // Units.
  std::string units = "mm";
  if (const C3dParameter* pu = out.findParameter("POINT", "UNITS"); pu && !pu->strings.empty() && !trim(pu->strings[0]).empty())
    units = std::string(trim(pu->strings[0]));
  l.to_m = findLengthUnitScale(units);
  if (l.to_m == 0) fail("POINT:UNITS", "expected a length unit mm, cm or m, got '" + units + "'");
  l.rate = rate;
  l.nch = nch;
  l.spf = spf;
}

// A float residual word no integer holds (the word is a float of camera mask x 256 + residual).
[[noreturn]] void failResidual(const C3dFile& out, long frame, int point, float r) {
  fail(out.path, "data/frame " + std::to_string(out.first_frame + frame) + "/point " + std::to_string(point + 1),
       "expected a residual word of -1 (missing) or 0..2147483647, got " + formatSignificant(r, 6));
}

// Marker positions in metres (NaN where the residual word is negative) and their residuals.
void readPoints(const std::vector<uint8_t>& b, const Codec& c, const Layout& l, C3dFile& out) {
  const std::string& path = out.path;
  const long first = l.first, frames = l.frames;
  const int npoints = l.npoints;
  const bool is_float = l.is_float;
  const double abs_scale = l.abs_scale, rate = l.rate, to_m = l.to_m;
  const size_t dstart = l.dstart, frame_bytes = l.frame_bytes;
  MarkerTable& m = out.markers;
  m.source_file = path;
  m.rate = rate;
  m.original_units = to_m == 1e-3 ? "mm" : to_m == 1e-2 ? "cm" : "m";
  std::vector<std::string> labels = joinStrings(out, "POINT", "LABELS");
  labels.resize(size_t(npoints));
  for (int i = 0; i < npoints; ++i)
    if (labels[size_t(i)].empty()) labels[size_t(i)] = "*" + std::to_string(i);
  m.labels = labels;
  m.time.resize(size_t(frames));
  m.frame_numbers.resize(size_t(frames));
  m.positions.resize(size_t(frames) * size_t(npoints));
  out.residuals.resize(m.positions.size());
  const double pos_scale = (is_float ? 1.0 : abs_scale) * to_m;
  for (long f = 0; f < frames; ++f) {
    m.frame_numbers[size_t(f)] = int(first + f);
    m.time[size_t(f)] = double(first + f - 1) / rate;
    const uint8_t* q = &b[dstart + size_t(f) * frame_bytes];
    for (int i = 0; i < npoints; ++i) {
      double x, y, z;
      int res_word;
      if (is_float) {
        x = c.f32(q); y = c.f32(q + 4); z = c.f32(q + 8);
        const float r = c.f32(q + 12);
        if (!(r < 2147483648.0f)) failResidual(out, f, i, r);  // NaN or beyond an int
        res_word = r < 0 ? -1 : int(r);
        q += 16;
      } else {
        x = c.i16(q); y = c.i16(q + 2); z = c.i16(q + 4);
        res_word = c.i16(q + 6);
        q += 8;
      }
      const size_t k = size_t(f) * size_t(npoints) + size_t(i);
      if (res_word < 0) {
        m.positions[k] = Eigen::Vector3d(kNaN, kNaN, kNaN);
        out.residuals[k] = kNaN;
      } else {
        m.positions[k] = Eigen::Vector3d(x * pos_scale, y * pos_scale, z * pos_scale);
        out.residuals[k] = double(res_word & 0xFF) * abs_scale * to_m;
      }
    }
  }
}

// Analog channels scaled to their units: (raw - OFFSET) * SCALE * GEN_SCALE.
void readAnalog(const std::vector<uint8_t>& b, const Codec& c, const Layout& l, C3dFile& out) {
  const long first = l.first, frames = l.frames;
  const int npoints = l.npoints, nch = l.nch, spf = l.spf;
  const bool is_float = l.is_float;
  const double rate = l.rate;
  const size_t dstart = l.dstart, frame_bytes = l.frame_bytes, word = l.word;
  AnalogTable& a = out.analog;
  a.samples_per_frame = spf;
  a.rate = firstValue(out, "ANALOG", "RATE", rate * spf);
  if (!(a.rate > 0)) a.rate = rate * spf;
  a.labels = joinStrings(out, "ANALOG", "LABELS");
  a.units = joinStrings(out, "ANALOG", "UNITS");
  a.descriptions = joinStrings(out, "ANALOG", "DESCRIPTIONS");
  a.labels.resize(size_t(nch));
  a.units.resize(size_t(nch));
  a.descriptions.resize(size_t(nch));
  for (int i = 0; i < nch; ++i)
    if (a.labels[size_t(i)].empty()) a.labels[size_t(i)] = "channel" + std::to_string(i + 1);
  std::string format = "SIGNED";
  if (const C3dParameter* pf2 = out.findParameter("ANALOG", "FORMAT"); pf2 && !pf2->strings.empty())
    format = toLower(trim(pf2->strings[0]));
  const bool unsigned_analog = equalsIgnoreCase(format, "unsigned");
  std::vector<double> ch_scale = joinValues(out, "ANALOG", "SCALE");
  std::vector<double> ch_offset = joinValues(out, "ANALOG", "OFFSET", unsigned_analog);
  ch_scale.resize(size_t(nch), 1.0);
  ch_offset.resize(size_t(nch), 0.0);
  const double gen_scale = firstValue(out, "ANALOG", "GEN_SCALE", 1.0);
  std::vector<double> mult(static_cast<size_t>(nch));
  for (int i = 0; i < nch; ++i) mult[size_t(i)] = ch_scale[size_t(i)] * gen_scale;
  const Eigen::Index nsamples = Eigen::Index(frames) * spf;
  // Decoded row by row in file order; a column-major fill would stride through the whole matrix.
  Eigen::Matrix<double, Eigen::Dynamic, Eigen::Dynamic, Eigen::RowMajor> rows(nsamples, nch);
  a.time.resize(size_t(nsamples));
  const double t0 = double(first - 1) / rate;
  for (Eigen::Index s = 0; s < nsamples; ++s) a.time[size_t(s)] = t0 + double(s) / a.rate;
  for (long f = 0; f < frames && nch > 0; ++f) {
    const uint8_t* q = &b[dstart + size_t(f) * frame_bytes + size_t(npoints) * 4 * word];
    for (int s = 0; s < spf; ++s) {
      const Eigen::Index row = Eigen::Index(f) * spf + s;
      for (int i = 0; i < nch; ++i) {
        double raw;
        if (is_float) {
          raw = c.f32(q);
          q += 4;
        } else {
          raw = unsigned_analog ? double(c.u16(q)) : double(c.i16(q));
          q += 2;
        }
        rows(row, i) = (raw - ch_offset[size_t(i)]) * mult[size_t(i)];
      }
    }
  }
  a.data = rows;
}

}  // namespace

int AnalogTable::findChannel(const std::string& label) const {
  for (size_t i = 0; i < labels.size(); ++i)
    if (labels[i] == label) return int(i);
  for (size_t i = 0; i < labels.size(); ++i)
    if (equalsIgnoreCase(labels[i], label)) return int(i);
  return -1;
}

C3dFile readC3d(const std::string& path) {
  const std::vector<uint8_t> b = readAllBytes(path);
  C3dFile out;
  out.path = path;
  const Codec c = readHeader(b, out);
  readParameterSection(path, b, c, out);
  Layout l;
  findFrames(out, l);
  findLayout(b, out, l);
  readPoints(b, c, l, out);
  readAnalog(b, c, l, out);
  readForcePlates(out, l.nch, l.to_m);
  return out;
}

}  // namespace kneesim::io
