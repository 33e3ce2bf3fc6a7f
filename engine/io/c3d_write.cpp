// Writing C3D files: the parameters regenerated from markers, analog channels and plates (and the
// source file's others), the groups, the header and the frames, in any of the three processor
// encodings.

#include <algorithm>
#include <cmath>
#include <map>

#include "core/atomic_file.hpp"
#include "core/error.hpp"
#include "core/strings.hpp"
#include "io/c3d_detail.hpp"
#include "io/text_fields.hpp"

namespace kneesim::io {

namespace {

using namespace detail;

// What the frames hold and how the file stores them.
struct WriteLayout {
  int np = 0, nf = 0, nch = 0, spf = 0;  // points, frames, analog channels, analog samples per frame
  double rate = 0;                       // Hz
  long first = 1, last = 0;              // frame numbers
  double stored_scale = 0;               // POINT:SCALE (negative: floats)
  double unit_m = 0, to_units = 0;       // o.units in metres, and metres to o.units
};

C3dParameter makeInts(const std::string& g, const std::string& n, const std::vector<double>& v, std::vector<int> dims) {
  C3dParameter p;
  p.group = g;
  p.name = n;
  p.type = 2;
  p.values = v;
  p.dims = std::move(dims);
  return p;
}

C3dParameter makeFloats(const std::string& g, const std::string& n, const std::vector<double>& v, std::vector<int> dims) {
  C3dParameter p = makeInts(g, n, v, std::move(dims));
  p.type = 4;
  return p;
}

C3dParameter makeString(const std::string& g, const std::string& n, const std::string& s) {
  C3dParameter p;
  p.group = g;
  p.name = n;
  p.type = -1;
  p.strings = {s};
  p.dims = {int(s.size())};
  return p;
}

// A list of strings (or numbers) split into BASE, BASE2, ... of at most 255 entries.
void addStringList(std::vector<C3dParameter>& out, const std::string& g, const std::string& base,
                   const std::vector<std::string>& items) {
  size_t width = 1;
  for (const auto& s : items) width = std::max(width, s.size());
  width = std::min<size_t>(width, 255);
  for (size_t start = 0, k = 1; start < items.size() || k == 1; start += 255, ++k) {
    C3dParameter p;
    p.group = g;
    p.name = k == 1 ? base : base + std::to_string(k);
    p.type = -1;
    const size_t n = std::min<size_t>(255, items.size() - std::min(start, items.size()));
    p.strings.assign(items.begin() + long(start), items.begin() + long(start + n));
    p.dims = {int(width), int(n)};
    out.push_back(p);
    if (start + 255 >= items.size()) break;
  }
}

void addValueList(std::vector<C3dParameter>& out, const std::string& g, const std::string& base,
                  const std::vector<double>& items, int type) {
  for (size_t start = 0, k = 1;; start += 255, ++k) {
    const size_t n = std::min<size_t>(255, items.size() - std::min(start, items.size()));
    C3dParameter p = makeInts(g, k == 1 ? base : base + std::to_string(k),
                              std::vector<double>(items.begin() + long(start), items.begin() + long(start + n)), {int(n)});
    p.type = type;
    out.push_back(p);
    if (start + 255 >= items.size()) break;
  }
}

Proc parseProc(const std::string& path, const std::string& s) {
  if (equalsIgnoreCase(s, "Intel")) return Proc::Intel;
  if (equalsIgnoreCase(s, "DEC")) return Proc::Dec;
  if (equalsIgnoreCase(s, "MIPS")) return Proc::Mips;
  throw InputError({path, 0, "processor"}, "expected Intel, DEC or MIPS, got '" + s + "'");
}

WriteLayout findWriteLayout(const std::string& path, const C3dFile& c3d, const C3dWriteOptions& o) {
  WriteLayout l;
  l.unit_m = findLengthUnitScale(o.units);
  if (l.unit_m == 0) throw InputError({path, 0, "units"}, "expected a length unit mm, cm or m, got '" + o.units + "'");
  KNEESIM_CHECK(o.point_scale > 0, "writeC3d: point_scale must be positive");
  const MarkerTable& m = c3d.markers;
  const int np = l.np = m.getNumMarkers();
  const int nf = l.nf = m.getNumFrames();
  KNEESIM_CHECK(m.positions.size() == size_t(np) * size_t(nf), "writeC3d: marker positions size mismatch");
  const AnalogTable& a = c3d.analog;
  const int nch = l.nch = int(a.data.cols());
  int& spf = l.spf;
  if (nch > 0) {
    KNEESIM_CHECK(nf > 0 && a.data.rows() % nf == 0, "writeC3d: analog rows must be a multiple of the frame count");
    spf = int(a.data.rows() / nf);
  }
  const double rate = l.rate = m.rate > 0 ? m.rate : c3d.header.frame_rate;
  KNEESIM_CHECK(rate > 0, "writeC3d: markers.rate must be positive");
  const long first = l.first = !m.frame_numbers.empty() ? m.frame_numbers.front() : std::max(1, c3d.first_frame);
  l.last = first + nf - 1;
  l.stored_scale = o.float_format ? -o.point_scale : o.point_scale;
  l.to_units = 1.0 / l.unit_m;
  return l;
}

// Analog scaling for integer files: a per-channel SCALE that covers the channel's range.
std::vector<double> analogScales(const AnalogTable& a, int nch, const C3dWriteOptions& o) {
  std::vector<double> ch_scale(size_t(nch), 1.0);
  if (!o.float_format)
    for (int i = 0; i < nch; ++i) {
      double mx = 0;
      for (Eigen::Index r = 0; r < a.data.rows(); ++r)
        if (std::isfinite(a.data(r, i))) mx = std::max(mx, std::fabs(a.data(r, i)));
      ch_scale[size_t(i)] = mx > 0 ? mx / 32000.0 : 1.0;
    }
  return ch_scale;
}

// The parameters writeC3d regenerates from markers, analog and plates (POINT, ANALOG,
// FORCE_PLATFORM, TRIAL), in writing order; POINT:DATA_START (index 2) is filled in later.
std::vector<C3dParameter> regeneratedParameters(const C3dFile& c3d, const C3dWriteOptions& o, const WriteLayout& l,
                                                const std::vector<double>& ch_scale) {
  const MarkerTable& m = c3d.markers;
  const AnalogTable& a = c3d.analog;
  const int np = l.np, nf = l.nf, nch = l.nch, spf = l.spf;
  const double rate = l.rate, stored_scale = l.stored_scale, to_units = l.to_units;
  const long first = l.first, last = l.last;
  std::vector<C3dParameter> params;
  params.push_back(makeInts("POINT", "USED", {double(np)}, {}));
  params.push_back(nf > 65535 ? makeFloats("POINT", "FRAMES", {double(nf)}, {}) : makeInts("POINT", "FRAMES", {double(nf)}, {}));
  params.push_back(makeInts("POINT", "DATA_START", {0.0}, {}));
  params.push_back(makeFloats("POINT", "SCALE", {stored_scale}, {}));
  params.push_back(makeFloats("POINT", "RATE", {rate}, {}));
  params.push_back(makeString("POINT", "UNITS", o.units));
  addStringList(params, "POINT", "LABELS", m.labels);
  params.push_back(makeInts("ANALOG", "USED", {double(nch)}, {}));
  params.push_back(makeFloats("ANALOG", "RATE", {nch > 0 ? (a.rate > 0 ? a.rate : rate * spf) : rate}, {}));
  params.push_back(makeFloats("ANALOG", "GEN_SCALE", {1.0}, {}));
  if (!o.float_format) params.push_back(makeString("ANALOG", "FORMAT", "SIGNED  "));  // room for "UNSIGNED"
  addValueList(params, "ANALOG", "SCALE", ch_scale, 4);
  addValueList(params, "ANALOG", "OFFSET", std::vector<double>(size_t(nch), 0.0), 2);
  std::vector<std::string> alabels = a.labels, aunits = a.units, adesc = a.descriptions;
  alabels.resize(size_t(nch));
  aunits.resize(size_t(nch));
  adesc.resize(size_t(nch));
  addStringList(params, "ANALOG", "LABELS", alabels);
  addStringList(params, "ANALOG", "UNITS", aunits);
  addStringList(params, "ANALOG", "DESCRIPTIONS", adesc);
  const int npl = int(c3d.plates.size());
  params.push_back(makeInts("FORCE_PLATFORM", "USED", {double(npl)}, {}));
  if (npl > 0) {
    std::vector<double> type, corners, origin, channel, cal;
    size_t per = 0;
    bool any_cal = false;
    for (const auto& p : c3d.plates) {
      per = std::max(per, p.channels.size());
      any_cal = any_cal || p.has_cal_matrix;
    }
    for (const auto& p : c3d.plates) {
      type.push_back(p.type);
      for (int k = 0; k < 4; ++k)
        for (int j = 0; j < 3; ++j) corners.push_back(p.corners_m(j, k) * to_units);
      for (int j = 0; j < 3; ++j) origin.push_back(p.origin_m[j] * to_units);
      for (size_t k = 0; k < per; ++k) channel.push_back(k < p.channels.size() ? p.channels[k] + 1 : 0);
      for (int j = 0; j < 6; ++j)
        for (int i = 0; i < 6; ++i) cal.push_back(p.cal_matrix(i, j));
    }
    params.push_back(makeInts("FORCE_PLATFORM", "TYPE", type, {npl}));
    params.push_back(makeFloats("FORCE_PLATFORM", "CORNERS", corners, {3, 4, npl}));
    params.push_back(makeFloats("FORCE_PLATFORM", "ORIGIN", origin, {3, npl}));
    params.push_back(makeInts("FORCE_PLATFORM", "CHANNEL", channel, {int(per), npl}));
    if (any_cal) params.push_back(makeFloats("FORCE_PLATFORM", "CAL_MATRIX", cal, {6, 6, npl}));
  }
  params.push_back(makeInts("TRIAL", "ACTUAL_START_FIELD", {double(first & 0xFFFF), double(first >> 16)}, {2}));
  params.push_back(makeInts("TRIAL", "ACTUAL_END_FIELD", {double(last & 0xFFFF), double(last >> 16)}, {2}));
  return params;
}

// Whether the source file's parameter @p p is one writeC3d regenerates (the first @p regenerated of
// @p params, their BASE2... continuations, and the plate and analog-format parameters).
bool isRegenerated(const std::vector<C3dParameter>& params, size_t regenerated, const C3dParameter& p) {
  for (size_t i = 0; i < regenerated; ++i)
    if (equalsIgnoreCase(params[i].group, p.group) &&
        (equalsIgnoreCase(params[i].name, p.name) ||
         ((params[i].name == "LABELS" || params[i].name == "UNITS" || params[i].name == "DESCRIPTIONS" ||
           params[i].name == "SCALE" || params[i].name == "OFFSET") &&
          isNameWithSuffix(p.name, params[i].name))))
      return true;
  if (equalsIgnoreCase(p.group, "FORCE_PLATFORM") &&
      (equalsIgnoreCase(p.name, "CAL_MATRIX") || equalsIgnoreCase(p.name, "TYPE") ||
       equalsIgnoreCase(p.name, "CORNERS") || equalsIgnoreCase(p.name, "ORIGIN") || equalsIgnoreCase(p.name, "CHANNEL")))
    return true;
  if (equalsIgnoreCase(p.group, "ANALOG") && equalsIgnoreCase(p.name, "FORMAT")) return true;
  return false;
}

// Groups: ids in order of first use; descriptions from the source where known. @p gid maps a
// lower-case group name to its id.
std::vector<C3dGroup> makeGroups(const std::vector<C3dParameter>& params, const C3dFile& c3d,
                                 std::map<std::string, int>& gid) {
  std::vector<C3dGroup> groups;
  for (const auto& p : params) {
    const std::string key = toLower(p.group);
    if (gid.count(key)) continue;
    C3dGroup g;
    g.id = int(groups.size()) + 1;
    g.name = p.group;
    for (const auto& src : c3d.groups)
      if (equalsIgnoreCase(src.name, p.group)) {
        g.description = src.description;
        g.locked = src.locked;
      }
    gid[key] = g.id;
    groups.push_back(g);
  }
  KNEESIM_CHECK(groups.size() < 127, "writeC3d: too many parameter groups");
  return groups;
}

// The parameter section: groups, then parameters, padded to whole blocks.
std::vector<uint8_t> encodeParameterSection(const Codec& c, const std::vector<C3dGroup>& groups,
                                            const std::vector<C3dParameter>& params, std::map<std::string, int>& gid) {
  std::vector<uint8_t> sec = {0x01, kC3dKey, 0, uint8_t(int(c.proc))};
  for (const auto& g : groups) encodeGroup(sec, c, g);
  for (size_t i = 0; i < params.size(); ++i)
    encodeParameter(sec, c, params[i], gid[toLower(params[i].group)], i + 1 == params.size());
  sec.resize((sec.size() + kC3dBlock - 1) / kC3dBlock * kC3dBlock, 0);
  KNEESIM_CHECK(sec.size() / kC3dBlock < 256, "writeC3d: parameter section longer than 255 blocks");
  sec[2] = uint8_t(sec.size() / kC3dBlock);
  return sec;
}

// The header block followed by the parameter section @p psec.
std::vector<uint8_t> encodeHeader(const Codec& c, const WriteLayout& l, int data_start, const std::vector<uint8_t>& psec) {
  const int np = l.np, nch = l.nch, spf = l.spf;
  const double rate = l.rate, stored_scale = l.stored_scale;
  const long first = l.first, last = l.last;
  std::vector<uint8_t> bytes(kC3dBlock, 0);
  bytes[0] = 2;
  bytes[1] = kC3dKey;
  c.putU16(&bytes[2], uint16_t(np));
  c.putU16(&bytes[4], uint16_t(nch * spf));
  c.putU16(&bytes[6], uint16_t(std::min<long>(first, 65535)));
  c.putU16(&bytes[8], uint16_t(std::min<long>(last, 65535)));
  c.putU16(&bytes[10], 10);
  c.putF32(&bytes[12], float(stored_scale));
  c.putU16(&bytes[16], uint16_t(data_start));
  c.putU16(&bytes[18], uint16_t(spf));
  c.putF32(&bytes[20], float(rate));
  bytes.insert(bytes.end(), psec.begin(), psec.end());
  return bytes;
}

// Appends the frames: per frame all points (x y z residual) then all analog samples.
void encodeFrames(const std::string& path, const C3dFile& c3d, const C3dWriteOptions& o, const WriteLayout& l,
                  const Codec& c, const std::vector<double>& ch_scale, std::vector<uint8_t>& bytes) {
  const MarkerTable& m = c3d.markers;
  const AnalogTable& a = c3d.analog;
  const int np = l.np, nf = l.nf, nch = l.nch, spf = l.spf;
  const double unit_m = l.unit_m, to_units = l.to_units;
  const size_t word = o.float_format ? 4 : 2;
  const size_t frame_bytes = (size_t(np) * 4 + size_t(nch) * size_t(spf)) * word;
  const size_t dstart = bytes.size();
  bytes.resize(dstart + frame_bytes * size_t(nf), 0);
  const double res_m = o.point_scale * unit_m;  // residual unit in metres
  for (int f = 0; f < nf; ++f) {
    uint8_t* q = &bytes[dstart + size_t(f) * frame_bytes];
    for (int i = 0; i < np; ++i) {
      const bool missing = m.isMissing(f, i);
      const Eigen::Vector3d p = missing ? Eigen::Vector3d::Zero() : Eigen::Vector3d(m.getPosition(f, i) * to_units);
      int res_word = -1;
      if (!missing) {
        const size_t k = size_t(f) * size_t(np) + size_t(i);
        const double r = k < c3d.residuals.size() && std::isfinite(c3d.residuals[k]) ? c3d.residuals[k] : 0.0;
        res_word = int(std::clamp<long>(std::lround(r / res_m), 0, 255));
      }
      if (o.float_format) {
        for (int j = 0; j < 3; ++j) c.putF32(q + 4 * j, float(p[j]));
        c.putF32(q + 12, float(res_word));
        q += 16;
      } else {
        for (int j = 0; j < 3; ++j) {
          const double counts = std::round(p[j] / o.point_scale);
          if (counts < -32768 || counts > 32767)
            throw InputError({path, 0, m.labels[size_t(i)]},
                             "coordinate " + std::to_string(p[j]) + " " + o.units + " does not fit a 16-bit integer at scale " +
                                 std::to_string(o.point_scale) + " (frame " + std::to_string(f + 1) +
                                 "): expected |value| <= " + std::to_string(32767 * o.point_scale) +
                                 "; use a float file or a coarser scale");
          c.putU16(q + 2 * j, uint16_t(int16_t(counts)));
        }
        c.putU16(q + 6, uint16_t(int16_t(res_word)));
        q += 8;
      }
    }
    for (int s = 0; s < spf; ++s)
      for (int i = 0; i < nch; ++i) {
        double v = a.data(Eigen::Index(f) * spf + s, i);
        if (!std::isfinite(v)) v = 0;
        if (o.float_format) {
          c.putF32(q, float(v));
          q += 4;
        } else {
          c.putU16(q, uint16_t(int16_t(std::clamp<long>(std::lround(v / ch_scale[size_t(i)]), -32768, 32767))));
          q += 2;
        }
      }
  }
}

}  // namespace

void writeC3d(const std::string& path, const C3dFile& c3d, const C3dWriteOptions& o) {
  Codec c;
  c.proc = parseProc(path, o.processor);
  const WriteLayout l = findWriteLayout(path, c3d, o);
  const std::vector<double> ch_scale = analogScales(c3d.analog, l.nch, o);

  // Parameters: regenerated ones first, then the file's others.
  std::vector<C3dParameter> params = regeneratedParameters(c3d, o, l, ch_scale);
  const size_t regenerated = params.size();
  for (const auto& p : c3d.parameters) {
    if (isRegenerated(params, regenerated, p)) continue;
    params.push_back(p);
  }
  // Keep the lock flag the source file had on regenerated parameters.
  for (size_t i = 0; i < regenerated; ++i)
    if (const C3dParameter* src = c3d.findParameter(params[i].group, params[i].name)) {
      params[i].locked = src->locked;
      params[i].description = src->description;
    }

  std::map<std::string, int> gid;
  const std::vector<C3dGroup> groups = makeGroups(params, c3d, gid);
  std::vector<uint8_t> psec = encodeParameterSection(c, groups, params, gid);
  const int data_start = 2 + int(psec.size() / kC3dBlock);
  params[2].values = {double(data_start)};  // POINT:DATA_START
  psec = encodeParameterSection(c, groups, params, gid);

  std::vector<uint8_t> bytes = encodeHeader(c, l, data_start, psec);
  encodeFrames(path, c3d, o, l, c, ch_scale, bytes);
  bytes.resize((bytes.size() + kC3dBlock - 1) / kC3dBlock * kC3dBlock, 0);

  AtomicFile file(path, true);
  file.stream().write(reinterpret_cast<const char*>(bytes.data()), std::streamsize(bytes.size()));
  file.commit();
}

}  // namespace kneesim::io
