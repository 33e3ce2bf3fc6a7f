#include "io/c3d.hpp"

#include <algorithm>
#include <cerrno>
#include <cmath>
#include <cstdint>
#include <cstring>
#include <fstream>
#include <limits>
#include <map>
#include <set>

#include <Eigen/Geometry>

#include "core/atomic_file.hpp"
#include "core/error.hpp"
#include "core/strings.hpp"
#include "io/text_fields.hpp"

namespace kneesim::io {

namespace {

constexpr int kBlock = 512;
constexpr uint8_t kKey = 0x50;
constexpr double kNaN = std::numeric_limits<double>::quiet_NaN();

enum class Proc { Intel = 84, Dec = 85, Mips = 86 };

const char* procName(Proc p) {
  switch (p) {
    case Proc::Intel: return "Intel";
    case Proc::Dec: return "DEC";
    case Proc::Mips: return "MIPS";
  }
  return "?";
}

// ---------------------------------------------------------------------------------------------
// Number encodings of the three processor types.

float decFloatToIeee(const uint8_t* b) {
  // VAX F-floating: two little-endian 16-bit words, the first holding sign, exponent (excess
  // 128) and the high mantissa; value = 0.1mmm... x 2^(e-128), i.e. (1 + f) x 2^(e-129).
  const uint32_t bits = uint32_t(b[2]) | (uint32_t(b[3]) << 8) | (uint32_t(b[0]) << 16) | (uint32_t(b[1]) << 24);
  const int exponent = int((bits >> 23) & 0xFF);
  if (exponent == 0) return 0.0f;  // DEC zero (a set sign bit would be a "reserved operand")
  const double mantissa = 1.0 + double(bits & 0x7FFFFF) / double(1 << 23);
  const double v = std::ldexp(mantissa, exponent - 129);
  return float((bits >> 31) ? -v : v);
}

void ieeeToDecFloat(float f, uint8_t* out) {
  std::memset(out, 0, 4);
  if (f == 0.0f || !std::isfinite(f)) return;
  int e2;
  const double m = std::frexp(double(std::fabs(f)), &e2);  // |f| = m 2^e2, m in [0.5, 1)
  const int exponent = e2 + 128;                          // DEC: 0.1mmm x 2^(e-128)
  if (exponent <= 0) return;                              // underflow: zero
  const int e = std::min(exponent, 255);
  const uint32_t frac = uint32_t(std::lround((m * 2.0 - 1.0) * double(1 << 23))) & 0x7FFFFF;
  const uint32_t bits = (f < 0 ? 0x80000000u : 0u) | (uint32_t(e) << 23) | frac;
  out[0] = uint8_t(bits >> 16);
  out[1] = uint8_t(bits >> 24);
  out[2] = uint8_t(bits);
  out[3] = uint8_t(bits >> 8);
}

struct Codec {
  Proc proc = Proc::Intel;

  uint16_t u16(const uint8_t* p) const {
    return proc == Proc::Mips ? uint16_t((p[0] << 8) | p[1]) : uint16_t(p[0] | (p[1] << 8));
  }
  int16_t i16(const uint8_t* p) const { return int16_t(u16(p)); }
  float f32(const uint8_t* p) const {
    if (proc == Proc::Dec) return decFloatToIeee(p);
    uint32_t u = proc == Proc::Mips ? (uint32_t(p[0]) << 24) | (uint32_t(p[1]) << 16) | (uint32_t(p[2]) << 8) | p[3]
                                    : uint32_t(p[0]) | (uint32_t(p[1]) << 8) | (uint32_t(p[2]) << 16) | (uint32_t(p[3]) << 24);
    float f;
    std::memcpy(&f, &u, 4);
    return f;
  }
  void putU16(uint8_t* p, uint16_t v) const {
    if (proc == Proc::Mips) {
      p[0] = uint8_t(v >> 8);
      p[1] = uint8_t(v);
    } else {
      p[0] = uint8_t(v);
      p[1] = uint8_t(v >> 8);
    }
  }
  void putF32(uint8_t* p, float f) const {
    if (proc == Proc::Dec) {
      ieeeToDecFloat(f, p);
      return;
    }
    uint32_t u;
    std::memcpy(&u, &f, 4);
    if (proc == Proc::Mips) {
      p[0] = uint8_t(u >> 24); p[1] = uint8_t(u >> 16); p[2] = uint8_t(u >> 8); p[3] = uint8_t(u);
    } else {
      p[0] = uint8_t(u); p[1] = uint8_t(u >> 8); p[2] = uint8_t(u >> 16); p[3] = uint8_t(u >> 24);
    }
  }
};

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

std::string rtrim(std::string s) {
  while (!s.empty() && (s.back() == ' ' || s.back() == '\0' || s.back() == '\t')) s.pop_back();
  return s;
}

// ---------------------------------------------------------------------------------------------
// Reading.

class Reader {
 public:
  Reader(const std::string& path, const std::vector<uint8_t>& bytes) : path_(path), b_(bytes) {}

  [[noreturn]] void fail(const std::string& element, const std::string& msg) const {
    throw InputError({path_, 0, element}, msg);
  }

  void parseParameters(C3dFile& out) {
    const size_t start = size_t(out.header.parameter_block - 1) * kBlock;
    size_t pos = start + 4;
    std::map<int, C3dGroup> groups;
    std::vector<std::pair<int, C3dParameter>> params;
    while (true) {
      if (pos + 2 > b_.size())
        fail("parameters", "expected a parameter or group at byte " + std::to_string(pos) +
                               ", the file ends at byte " + std::to_string(b_.size()) + " (truncated parameter section)");
      const int name_len = int(int8_t(b_[pos]));
      const int gid = int(int8_t(b_[pos + 1]));
      if (name_len == 0 || gid == 0) break;  // end of the parameter section
      const size_t nlen = size_t(std::abs(name_len));
      need(pos + 2 + nlen + 2, "parameter name and offset");
      std::string name(reinterpret_cast<const char*>(&b_[pos + 2]), nlen);
      const size_t p = pos + 2 + nlen;
      const int offset = codec_.i16(&b_[p]);
      if (gid < 0) {
        need(p + 3, "group '" + name + "' description length");
        const size_t dlen = b_[p + 2];
        need(p + 3 + dlen, "group '" + name + "' description");
        C3dGroup g;
        g.id = -gid;
        g.name = name;
        g.locked = name_len < 0;
        g.description = rtrim(std::string(reinterpret_cast<const char*>(&b_[p + 3]), dlen));
        groups[g.id] = g;
      } else {
        C3dParameter prm;
        prm.name = name;
        prm.locked = name_len < 0;
        need(p + 4, "parameter '" + name + "' type and dimensions");
        prm.type = int(int8_t(b_[p + 2]));
        const int nd = b_[p + 3];
        if (prm.type != -1 && prm.type != 1 && prm.type != 2 && prm.type != 4)
          fail("parameters/" + name, "expected a parameter type of -1, 1, 2 or 4, got " + std::to_string(prm.type));
        need(p + 4 + size_t(nd), "parameter '" + name + "' dimensions");
        size_t count = 1;
        for (int d = 0; d < nd; ++d) {
          prm.dims.push_back(b_[p + 4 + size_t(d)]);
          count *= size_t(prm.dims.back());
          if (count > b_.size())  // also stops the product from overflowing
            fail("parameters/" + name, "expected parameter data within the file, got dimensions of more than " +
                                           std::to_string(b_.size()) + " elements");
        }
        const size_t elem = size_t(std::abs(prm.type));
        const size_t data = p + 4 + size_t(nd);
        need(data + count * elem + 1, "parameter '" + name + "' data");
        if (prm.type == -1) {
          const size_t len = prm.dims.empty() ? 1 : size_t(prm.dims[0]);
          const size_t n = len == 0 ? 0 : count / len;
          for (size_t i = 0; i < n; ++i)
            prm.strings.push_back(rtrim(std::string(reinterpret_cast<const char*>(&b_[data + i * len]), len)));
        } else {
          prm.values.resize(count);
          for (size_t i = 0; i < count; ++i) {
            const uint8_t* q = &b_[data + i * elem];
            prm.values[i] = prm.type == 1 ? double(*q) : prm.type == 2 ? double(codec_.i16(q)) : double(codec_.f32(q));
          }
        }
        const size_t dpos = data + count * elem;
        const size_t dlen = b_[dpos];
        need(dpos + 1 + dlen, "parameter '" + name + "' description");
        prm.description = rtrim(std::string(reinterpret_cast<const char*>(&b_[dpos + 1]), dlen));
        params.emplace_back(gid, std::move(prm));
      }
      if (offset == 0) break;
      if (offset < 0)
        fail("parameters/" + name, "expected a positive offset to the next parameter, got " + std::to_string(offset));
      pos = p + size_t(offset);
    }
    for (auto& [id, g] : groups) out.groups.push_back(g);
    for (auto& [gid, prm] : params) {
      auto it = groups.find(gid);
      prm.group = it != groups.end() ? it->second.name : "GROUP" + std::to_string(gid);
      out.parameters.push_back(std::move(prm));
    }
  }

  void setCodec(Proc p) { codec_.proc = p; }
  const Codec& codec() const { return codec_; }

  void need(size_t end, const std::string& what) const {
    if (end > b_.size())
      fail("parameters", "expected " + what + " up to byte " + std::to_string(end) + ", the file ends at byte " +
                             std::to_string(b_.size()) + " (truncated parameter section)");
  }

 private:
  const std::string& path_;
  const std::vector<uint8_t>& b_;
  Codec codec_;
};

bool isNameWithSuffix(const std::string& name, const std::string& base) {
  if (!startsWith(toLower(name), toLower(base))) return false;
  const std::string rest = name.substr(base.size());
  if (rest.empty()) return true;
  return std::all_of(rest.begin(), rest.end(), [](char c) { return c >= '0' && c <= '9'; });
}

// BASE, BASE2, BASE3, ... joined (C3D splits arrays longer than 255 entries this way).
const C3dParameter* find(const C3dFile& f, const char* g, const std::string& n) { return f.findParameter(g, n); }

std::vector<std::string> joinStrings(const C3dFile& f, const char* group, const std::string& base) {
  std::vector<std::string> out;
  for (int k = 1;; ++k) {
    const C3dParameter* p = find(f, group, k == 1 ? base : base + std::to_string(k));
    if (!p) break;
    out.insert(out.end(), p->strings.begin(), p->strings.end());
  }
  return out;
}

std::vector<double> joinValues(const C3dFile& f, const char* group, const std::string& base, bool as_unsigned = false) {
  std::vector<double> out;
  for (int k = 1;; ++k) {
    const C3dParameter* p = find(f, group, k == 1 ? base : base + std::to_string(k));
    if (!p) break;
    for (int i = 0; i < p->getNumValues(); ++i) out.push_back(as_unsigned ? p->getUnsigned(i) : p->values[size_t(i)]);
  }
  return out;
}

double firstValue(const C3dFile& f, const char* group, const char* name, double fallback, bool as_unsigned = false) {
  const C3dParameter* p = find(f, group, name);
  if (!p || p->values.empty()) return fallback;
  return as_unsigned ? p->getUnsigned(0) : p->values[0];
}

// Frame number stored as two 16-bit words (low, high) in TRIAL:ACTUAL_START_FIELD/END_FIELD.
bool trialField(const C3dFile& f, const char* name, long& out) {
  const C3dParameter* p = find(f, "TRIAL", name);
  if (!p || p->values.empty()) return false;
  out = long(p->getUnsigned(0)) + (p->values.size() > 1 ? 65536L * long(p->getUnsigned(1)) : 0L);
  return true;
}

}  // namespace

double C3dParameter::getUnsigned(int i) const {
  const double v = values[size_t(i)];
  if (type == 2 && v < 0) return v + 65536.0;
  return v;
}

int AnalogTable::findChannel(const std::string& label) const {
  for (size_t i = 0; i < labels.size(); ++i)
    if (labels[i] == label) return int(i);
  for (size_t i = 0; i < labels.size(); ++i)
    if (equalsIgnoreCase(labels[i], label)) return int(i);
  return -1;
}

const C3dParameter* C3dFile::findParameter(const std::string& group, const std::string& name) const {
  for (const auto& p : parameters)
    if (equalsIgnoreCase(p.group, group) && equalsIgnoreCase(p.name, name)) return &p;
  return nullptr;
}

C3dFile readC3d(const std::string& path) {
  const std::vector<uint8_t> b = readAllBytes(path);
  C3dFile out;
  out.path = path;
  auto fail = [&](const std::string& element, const std::string& msg) -> void {
    throw InputError({path, 0, element}, msg);
  };
  if (b.size() < size_t(kBlock))
    fail("header", "expected a C3D header of 512 bytes, the file has " + std::to_string(b.size()) + " bytes");
  if (b[1] != kKey)
    fail("header", "expected the C3D key byte 0x50 at byte 2, got 0x" +
                       std::string(1, "0123456789abcdef"[b[1] >> 4]) + std::string(1, "0123456789abcdef"[b[1] & 15]) +
                       " (not a C3D file?)");
  out.header.parameter_block = b[0];
  if (b[0] == 0) fail("header", "expected a parameter section block number of 1 or more, got 0");
  const size_t pstart = size_t(b[0] - 1) * kBlock;
  if (pstart + 4 > b.size())
    fail("header", "parameter section pointer (block " + std::to_string(b[0]) + ", byte " + std::to_string(pstart) +
                       ") points past the end of the file (" + std::to_string(b.size()) + " bytes)");
  const int proc_byte = b[pstart + 3];
  if (proc_byte != 84 && proc_byte != 85 && proc_byte != 86)
    fail("parameters", "expected processor type 84 (Intel), 85 (DEC) or 86 (MIPS) in the parameter header, got " +
                           std::to_string(proc_byte));
  const Proc proc = Proc(proc_byte);
  out.processor = procName(proc);

  Reader reader(path, b);
  reader.setCodec(proc);
  const Codec& c = reader.codec();
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

  reader.parseParameters(out);

  // Frames: the header holds 16-bit numbers; TRIAL fields and POINT:FRAMES hold longer trials.
  long first = h.first_frame, last = h.last_frame;
  const bool have_trial = trialField(out, "ACTUAL_START_FIELD", first) && trialField(out, "ACTUAL_END_FIELD", last);
  if (!have_trial) {
    first = h.first_frame;
    last = h.last_frame;
  }
  long frames = last - first + 1;
  const C3dParameter* pf = out.findParameter("POINT", "FRAMES");
  if (!have_trial && pf && !pf->values.empty()) {
    const long n = long(pf->getUnsigned(0));
    if (n > frames) frames = n;  // header last frame saturated at 65535
  }
  if (frames < 0) frames = 0;
  if (frames > 100000000L)
    fail("POINT:FRAMES", "expected at most 100000000 frames, got " + std::to_string(frames) + " (corrupt header?)");
  if (first < 1 && frames > 0) first = 1;
  out.first_frame = int(first);
  out.last_frame = int(first + frames - 1);

  // Layout.
  const int npoints = h.num_points;
  double scale = firstValue(out, "POINT", "SCALE", h.scale);
  if (scale == 0) scale = h.scale;
  const bool is_float = scale < 0;
  const double abs_scale = std::fabs(scale);
  double rate = firstValue(out, "POINT", "RATE", h.frame_rate);
  if (!(rate > 0)) rate = h.frame_rate;
  if (frames > 0 && !(rate > 0))
    fail("POINT:RATE", "expected a positive frame rate, got " + std::to_string(rate));

  int nch = int(firstValue(out, "ANALOG", "USED", -1, true));
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
  if (data_start == 0) data_start = int(firstValue(out, "POINT", "DATA_START", 0, true));
  if (data_start < 1) fail("header", "expected a data start block of 1 or more, got " + std::to_string(data_start));
  const size_t word = is_float ? 4 : 2;
  const size_t frame_bytes = (size_t(npoints) * 4 + size_t(h.analog_per_frame)) * word;
  const size_t dstart = size_t(data_start - 1) * kBlock;
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
  const double to_m = detail::findLengthUnitScale(units);
  if (to_m == 0) fail("POINT:UNITS", "expected a length unit mm, cm or m, got '" + units + "'");

  // Markers.
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

  // Analog channels.
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

  // Force platforms.
  const int nplates = int(firstValue(out, "FORCE_PLATFORM", "USED", 0));
  if (nplates > 0) {
    const C3dParameter* pt = out.findParameter("FORCE_PLATFORM", "TYPE");
    const C3dParameter* pc = out.findParameter("FORCE_PLATFORM", "CORNERS");
    const C3dParameter* po = out.findParameter("FORCE_PLATFORM", "ORIGIN");
    const C3dParameter* pch = out.findParameter("FORCE_PLATFORM", "CHANNEL");
    const C3dParameter* pcal = out.findParameter("FORCE_PLATFORM", "CAL_MATRIX");
    auto require = [&](const C3dParameter* p, const char* name, size_t n) {
      if (!p) fail(std::string("FORCE_PLATFORM:") + name, "expected this parameter for FORCE_PLATFORM:USED = " +
                                                              std::to_string(nplates) + " plates, not found");
      if (p->values.size() < n)
        fail(std::string("FORCE_PLATFORM:") + name, "expected at least " + std::to_string(n) + " values for " +
                                                        std::to_string(nplates) + " plates, got " +
                                                        std::to_string(p->values.size()));
    };
    require(pt, "TYPE", size_t(nplates));
    require(pc, "CORNERS", size_t(12 * nplates));
    require(po, "ORIGIN", size_t(3 * nplates));
    require(pch, "CHANNEL", size_t(nplates));
    const size_t per_plate = pch->dims.empty() ? 1 : size_t(pch->dims[0]);
    require(pch, "CHANNEL", per_plate * size_t(nplates));
    for (int p = 0; p < nplates; ++p) {
      ForcePlate fp;
      fp.type = int(pt->values[size_t(p)]);
      for (int k = 0; k < 4; ++k)
        for (int j = 0; j < 3; ++j) fp.corners_m(j, k) = pc->values[size_t(12 * p + 3 * k + j)] * to_m;
      for (int j = 0; j < 3; ++j) fp.origin_m[j] = po->values[size_t(3 * p + j)] * to_m;
      for (size_t k = 0; k < per_plate; ++k) {
        const int chn = int(pch->values[size_t(p) * per_plate + k]);
        if (chn < 1 || chn > nch)
          fail("FORCE_PLATFORM:CHANNEL", "plate " + std::to_string(p + 1) + ": expected analog channel numbers 1.." +
                                             std::to_string(nch) + ", got " + std::to_string(chn));
        fp.channels.push_back(chn - 1);
      }
      fp.cal_matrix.setIdentity();
      if (pcal && pcal->dims.size() >= 2 && pcal->dims[0] == 6 && pcal->dims[1] == 6 &&
          pcal->values.size() >= size_t(36 * (p + 1))) {
        for (int j = 0; j < 6; ++j)
          for (int i = 0; i < 6; ++i) fp.cal_matrix(i, j) = pcal->values[size_t(36 * p + 6 * j + i)];
        fp.has_cal_matrix = true;
      }
      out.plates.push_back(fp);
    }
  }
  return out;
}

// ---------------------------------------------------------------------------------------------
// Writing.

namespace {

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

size_t elementCount(const C3dParameter& p) {
  size_t n = 1;
  for (int d : p.dims) n *= size_t(d);
  return n;
}

void encodeParameter(std::vector<uint8_t>& out, const Codec& c, const C3dParameter& p, int gid, bool last) {
  const std::string name = p.name.substr(0, 127);
  out.push_back(uint8_t(int8_t(p.locked ? -int(name.size()) : int(name.size()))));
  out.push_back(uint8_t(int8_t(gid)));
  out.insert(out.end(), name.begin(), name.end());
  const size_t off_pos = out.size();
  out.resize(out.size() + 2);
  out.push_back(uint8_t(int8_t(p.type)));
  out.push_back(uint8_t(p.dims.size()));
  for (int d : p.dims) out.push_back(uint8_t(d));
  const size_t n = elementCount(p);
  if (p.type == -1) {
    const size_t width = p.dims.empty() ? 1 : size_t(p.dims[0]);
    const size_t count = width == 0 ? 0 : n / width;
    for (size_t i = 0; i < count; ++i) {
      std::string s = i < p.strings.size() ? p.strings[i] : std::string();
      s.resize(width, ' ');
      out.insert(out.end(), s.begin(), s.end());
    }
  } else {
    for (size_t i = 0; i < n; ++i) {
      const double v = i < p.values.size() ? p.values[i] : 0.0;
      uint8_t buf[4];
      if (p.type == 1) {
        out.push_back(uint8_t(std::lround(std::clamp(v, 0.0, 255.0))));
      } else if (p.type == 2) {
        c.putU16(buf, uint16_t(int32_t(std::lround(std::clamp(v, -32768.0, 65535.0)))));
        out.insert(out.end(), buf, buf + 2);
      } else {
        c.putF32(buf, float(v));
        out.insert(out.end(), buf, buf + 4);
      }
    }
  }
  const std::string desc = p.description.substr(0, 255);
  out.push_back(uint8_t(desc.size()));
  out.insert(out.end(), desc.begin(), desc.end());
  c.putU16(&out[off_pos], last ? 0 : uint16_t(out.size() - off_pos));
}

void encodeGroup(std::vector<uint8_t>& out, const Codec& c, const C3dGroup& g) {
  const std::string name = g.name.substr(0, 127);
  out.push_back(uint8_t(int8_t(g.locked ? -int(name.size()) : int(name.size()))));
  out.push_back(uint8_t(int8_t(-g.id)));
  out.insert(out.end(), name.begin(), name.end());
  const size_t off_pos = out.size();
  out.resize(out.size() + 2);
  const std::string desc = g.description.substr(0, 255);
  out.push_back(uint8_t(desc.size()));
  out.insert(out.end(), desc.begin(), desc.end());
  c.putU16(&out[off_pos], uint16_t(out.size() - off_pos));
}

Proc parseProc(const std::string& path, const std::string& s) {
  if (equalsIgnoreCase(s, "Intel")) return Proc::Intel;
  if (equalsIgnoreCase(s, "DEC")) return Proc::Dec;
  if (equalsIgnoreCase(s, "MIPS")) return Proc::Mips;
  throw InputError({path, 0, "processor"}, "expected Intel, DEC or MIPS, got '" + s + "'");
}

}  // namespace

void writeC3d(const std::string& path, const C3dFile& c3d, const C3dWriteOptions& o) {
  Codec c;
  c.proc = parseProc(path, o.processor);
  const double unit_m = detail::findLengthUnitScale(o.units);
  if (unit_m == 0) throw InputError({path, 0, "units"}, "expected a length unit mm, cm or m, got '" + o.units + "'");
  KNEESIM_CHECK(o.point_scale > 0, "writeC3d: point_scale must be positive");
  const MarkerTable& m = c3d.markers;
  const int np = m.getNumMarkers();
  const int nf = m.getNumFrames();
  KNEESIM_CHECK(m.positions.size() == size_t(np) * size_t(nf), "writeC3d: marker positions size mismatch");
  const AnalogTable& a = c3d.analog;
  const int nch = int(a.data.cols());
  int spf = 0;
  if (nch > 0) {
    KNEESIM_CHECK(nf > 0 && a.data.rows() % nf == 0, "writeC3d: analog rows must be a multiple of the frame count");
    spf = int(a.data.rows() / nf);
  }
  const double rate = m.rate > 0 ? m.rate : c3d.header.frame_rate;
  KNEESIM_CHECK(rate > 0, "writeC3d: markers.rate must be positive");
  const long first = !m.frame_numbers.empty() ? m.frame_numbers.front() : std::max(1, c3d.first_frame);
  const long last = first + nf - 1;
  const double stored_scale = o.float_format ? -o.point_scale : o.point_scale;
  const double to_units = 1.0 / unit_m;

  // Analog scaling for integer files.
  std::vector<double> ch_scale(size_t(nch), 1.0);
  if (!o.float_format)
    for (int i = 0; i < nch; ++i) {
      double mx = 0;
      for (Eigen::Index r = 0; r < a.data.rows(); ++r)
        if (std::isfinite(a.data(r, i))) mx = std::max(mx, std::fabs(a.data(r, i)));
      ch_scale[size_t(i)] = mx > 0 ? mx / 32000.0 : 1.0;
    }

  // Parameters: regenerated ones first, then the file's others.
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
  const size_t regenerated = params.size();
  auto isRegenerated = [&](const C3dParameter& p) {
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
  };
  for (const auto& p : c3d.parameters) {
    if (isRegenerated(p)) continue;
    params.push_back(p);
  }
  // Keep the lock flag the source file had on regenerated parameters.
  for (size_t i = 0; i < regenerated; ++i)
    if (const C3dParameter* src = c3d.findParameter(params[i].group, params[i].name)) {
      params[i].locked = src->locked;
      params[i].description = src->description;
    }

  // Groups: ids in order of first use; descriptions from the source where known.
  std::vector<C3dGroup> groups;
  std::map<std::string, int> gid;
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

  auto encodeAll = [&]() {
    std::vector<uint8_t> sec = {0x01, kKey, 0, uint8_t(int(c.proc))};
    for (const auto& g : groups) encodeGroup(sec, c, g);
    for (size_t i = 0; i < params.size(); ++i)
      encodeParameter(sec, c, params[i], gid[toLower(params[i].group)], i + 1 == params.size());
    sec.resize((sec.size() + kBlock - 1) / kBlock * kBlock, 0);
    KNEESIM_CHECK(sec.size() / kBlock < 256, "writeC3d: parameter section longer than 255 blocks");
    sec[2] = uint8_t(sec.size() / kBlock);
    return sec;
  };
  std::vector<uint8_t> psec = encodeAll();
  const int data_start = 2 + int(psec.size() / kBlock);
  params[2].values = {double(data_start)};  // POINT:DATA_START
  psec = encodeAll();

  // Header.
  std::vector<uint8_t> bytes(kBlock, 0);
  bytes[0] = 2;
  bytes[1] = kKey;
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

  // Frames.
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
  bytes.resize((bytes.size() + kBlock - 1) / kBlock * kBlock, 0);

  AtomicFile file(path, true);
  file.stream().write(reinterpret_cast<const char*>(bytes.data()), std::streamsize(bytes.size()));
  file.commit();
}

// ---------------------------------------------------------------------------------------------
// Force plates.

namespace {

double forceUnitToNewtons(const std::string& u) {
  std::string s;
  for (char ch : toLower(trim(u)))
    if (ch != ' ' && ch != '.' && ch != '*' && ch != '-' && ch != '_') s += ch;
  if (s.empty() || s == "n") return 1.0;
  if (s == "kn") return 1000.0;
  if (s == "lbf" || s == "lb") return 4.4482216152605;
  return 0.0;
}

double momentUnitToNewtonMetres(const std::string& u, double default_scale) {
  std::string s;
  for (char ch : toLower(trim(u)))
    if (ch != ' ' && ch != '.' && ch != '*' && ch != '-' && ch != '_') s += ch;
  if (s.empty()) return default_scale;
  if (s == "nmm" || s == "mmn") return 1e-3;
  if (s == "nm" || s == "mn") return 1.0;
  if (s == "ncm") return 1e-2;
  if (s == "knm") return 1e3;
  return 0.0;
}

}  // namespace

PlateWrench calcPlateWrench(const C3dFile& c3d, int plate, double min_normal_force) {
  const std::string element = "FORCE_PLATFORM[" + std::to_string(plate + 1) + "]";
  if (plate < 0 || plate >= int(c3d.plates.size()))
    throw InputError({c3d.path, 0, element}, "expected a plate index 0.." + std::to_string(int(c3d.plates.size()) - 1) +
                                                 ", got " + std::to_string(plate));
  const ForcePlate& fp = c3d.plates[size_t(plate)];
  if (fp.type != 2 && fp.type != 4)
    throw InputError({c3d.path, 0, element}, "expected force-plate type 2 or 4 (six-component), got type " + std::to_string(fp.type));
  if (fp.channels.size() < 6)
    throw InputError({c3d.path, 0, element}, "expected 6 channels (Fx Fy Fz Mx My Mz), got " + std::to_string(fp.channels.size()));
  const AnalogTable& a = c3d.analog;

  // Units per channel.
  const double length_default = c3d.markers.original_units == "m" ? 1.0 : c3d.markers.original_units == "cm" ? 1e-2 : 1e-3;
  double unit[6];
  for (int k = 0; k < 6; ++k) {
    const int ch = fp.channels[size_t(k)];
    const std::string u = size_t(ch) < a.units.size() ? a.units[size_t(ch)] : std::string();
    unit[k] = k < 3 ? forceUnitToNewtons(u) : momentUnitToNewtonMetres(u, length_default);
    if (unit[k] == 0)
      throw InputError({c3d.path, 0, "ANALOG:UNITS[" + a.labels[size_t(ch)] + "]"},
                       std::string("expected a ") + (k < 3 ? "force unit N, kN or lbf" : "moment unit N mm or N m") +
                           ", got '" + u + "'");
  }

  // Plate frame from the corners.
  const Eigen::Vector3d c1 = fp.corners_m.col(0), c2 = fp.corners_m.col(1), c4 = fp.corners_m.col(3);
  Eigen::Vector3d x = c1 - c2;
  const Eigen::Vector3d y0 = c1 - c4;
  Eigen::Vector3d z = x.cross(y0);
  if (!(x.norm() > 0) || !(z.norm() > 0))
    throw InputError({c3d.path, 0, element + "/CORNERS"}, "expected four corners spanning a plane, got a degenerate plate");
  x.normalize();
  z.normalize();
  const Eigen::Vector3d y = z.cross(x);
  Eigen::Matrix3d R_LP;
  R_LP.col(0) = x;
  R_LP.col(1) = y;
  R_LP.col(2) = z;
  const Eigen::Vector3d p_LC = fp.corners_m.rowwise().mean();  // centre of the working surface
  Eigen::Vector3d r_OC = fp.origin_m;                          // sensor origin -> surface centre, plate frame
  if (r_OC.z() > 0) r_OC = -r_OC;

  PlateWrench w;
  const Eigen::Index n = a.data.rows();
  w.force.resize(size_t(n));
  w.cop.resize(size_t(n));
  w.free_moment.resize(size_t(n));
  const Eigen::Vector3d nan3(kNaN, kNaN, kNaN);
  for (Eigen::Index s = 0; s < n; ++s) {
    Eigen::Matrix<double, 6, 1> raw;
    for (int k = 0; k < 6; ++k) raw[k] = a.data(s, fp.channels[size_t(k)]) * unit[k];
    if (fp.type == 4) raw = fp.cal_matrix * raw;
    const Eigen::Vector3d F = raw.head<3>();
    // Moment about the surface centre C: M_C = M_O + (O - C) x F = M_O + F x r_OC.
    const Eigen::Vector3d M_C = raw.tail<3>() + F.cross(r_OC);
    w.force[size_t(s)] = R_LP * F;
    if (!(std::fabs(F.z()) >= min_normal_force)) {
      w.cop[size_t(s)] = nan3;
      w.free_moment[size_t(s)] = nan3;
      continue;
    }
    // A force F at p = (px, py, 0) from C plus a free moment Tz about the normal gives
    // M_C = p x F + Tz e_z, so px = -My/Fz, py = Mx/Fz, Tz = Mz - (px Fy - py Fx).
    const double px = -M_C.y() / F.z();
    const double py = M_C.x() / F.z();
    const double tz = M_C.z() - (px * F.y() - py * F.x());
    w.cop[size_t(s)] = p_LC + R_LP * Eigen::Vector3d(px, py, 0.0);
    w.free_moment[size_t(s)] = R_LP * Eigen::Vector3d(0.0, 0.0, tz);
  }
  return w;
}

}  // namespace kneesim::io
