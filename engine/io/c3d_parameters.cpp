// The parameter section of C3D files: decoding groups and parameters (with every length checked
// against the file), encoding them, and looking parameters up (BASE, BASE2, ... joined).

#include <algorithm>
#include <cmath>
#include <map>

#include "core/error.hpp"
#include "core/strings.hpp"
#include "io/c3d_detail.hpp"

namespace kneesim::io {

double C3dParameter::getUnsigned(int i) const {
  const double v = values[size_t(i)];
  if (type == 2 && v < 0) return v + 65536.0;
  return v;
}

const C3dParameter* C3dFile::findParameter(const std::string& group, const std::string& name) const {
  for (const auto& p : parameters)
    if (equalsIgnoreCase(p.group, group) && equalsIgnoreCase(p.name, name)) return &p;
  return nullptr;
}

namespace detail {

std::string rtrimC3d(std::string s) {
  while (!s.empty() && (s.back() == ' ' || s.back() == '\0' || s.back() == '\t')) s.pop_back();
  return s;
}

namespace {

// Decodes the parameter section, checking every length against the file's end.
class Reader {
 public:
  Reader(const std::string& path, const std::vector<uint8_t>& bytes, const Codec& codec)
      : path_(path), b_(bytes), codec_(codec) {}

  [[noreturn]] void fail(const std::string& element, const std::string& msg) const {
    throw InputError({path_, 0, element}, msg);
  }

  void parseParameters(C3dFile& out) {
    const size_t start = size_t(out.header.parameter_block - 1) * kC3dBlock;
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
        g.description = rtrimC3d(std::string(reinterpret_cast<const char*>(&b_[p + 3]), dlen));
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
            prm.strings.push_back(rtrimC3d(std::string(reinterpret_cast<const char*>(&b_[data + i * len]), len)));
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
        prm.description = rtrimC3d(std::string(reinterpret_cast<const char*>(&b_[dpos + 1]), dlen));
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

  void need(size_t end, const std::string& what) const {
    if (end > b_.size())
      fail("parameters", "expected " + what + " up to byte " + std::to_string(end) + ", the file ends at byte " +
                             std::to_string(b_.size()) + " (truncated parameter section)");
  }

 private:
  const std::string& path_;
  const std::vector<uint8_t>& b_;
  const Codec& codec_;
};

size_t elementCount(const C3dParameter& p) {
  size_t n = 1;
  for (int d : p.dims) n *= size_t(d);
  return n;
}

}  // namespace

void readParameterSection(const std::string& path, const std::vector<uint8_t>& bytes, const Codec& codec,
                          C3dFile& out) {
  Reader(path, bytes, codec).parseParameters(out);
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

bool isNameWithSuffix(const std::string& name, const std::string& base) {
  if (!startsWith(toLower(name), toLower(base))) return false;
  const std::string rest = name.substr(base.size());
  if (rest.empty()) return true;
  return std::all_of(rest.begin(), rest.end(), [](char c) { return c >= '0' && c <= '9'; });
}

namespace {

const C3dParameter* find(const C3dFile& f, const char* g, const std::string& n) { return f.findParameter(g, n); }

}  // namespace

std::vector<std::string> joinStrings(const C3dFile& f, const char* group, const std::string& base) {
  std::vector<std::string> out;
  for (int k = 1;; ++k) {
    const C3dParameter* p = find(f, group, k == 1 ? base : base + std::to_string(k));
    if (!p) break;
    out.insert(out.end(), p->strings.begin(), p->strings.end());
  }
  return out;
}

std::vector<double> joinValues(const C3dFile& f, const char* group, const std::string& base, bool as_unsigned) {
  std::vector<double> out;
  for (int k = 1;; ++k) {
    const C3dParameter* p = find(f, group, k == 1 ? base : base + std::to_string(k));
    if (!p) break;
    for (int i = 0; i < p->getNumValues(); ++i) out.push_back(as_unsigned ? p->getUnsigned(i) : p->values[size_t(i)]);
  }
  return out;
}

double firstValue(const C3dFile& f, const char* group, const char* name, double fallback, bool as_unsigned) {
  const C3dParameter* p = find(f, group, name);
  if (!p || p->values.empty()) return fallback;
  return as_unsigned ? p->getUnsigned(0) : p->values[0];
}

bool trialField(const C3dFile& f, const char* name, long& out) {
  const C3dParameter* p = find(f, "TRIAL", name);
  if (!p || p->values.empty()) return false;
  const std::string element = std::string("TRIAL:") + name;
  out = toWhole(f, p->getUnsigned(0), 0, 65535, element);
  if (p->values.size() > 1) out += 65536L * toWhole(f, p->getUnsigned(1), 0, 65535, element);
  return true;
}

long toWhole(const C3dFile& f, double v, long lo, long hi, const std::string& element) {
  if (!(v >= double(lo) && v < double(hi) + 1.0))
    throw InputError({f.path, 0, element}, "expected a whole number in " + std::to_string(lo) + ".." +
                                               std::to_string(hi) + ", got " + formatSignificant(v, 6));
  return long(v);
}

long firstWhole(const C3dFile& f, const char* group, const char* name, long fallback, long lo, long hi,
                bool as_unsigned) {
  const C3dParameter* p = find(f, group, name);
  if (!p || p->values.empty()) return fallback;
  return toWhole(f, as_unsigned ? p->getUnsigned(0) : p->values[0], lo, hi, std::string(group) + ":" + name);
}

}  // namespace detail
}  // namespace kneesim::io
