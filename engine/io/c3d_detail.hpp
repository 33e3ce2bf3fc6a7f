#pragma once
// Internal to the C3D reader and writer (io/c3d.hpp): the block layout, the number encodings of the
// three processor types, and the steps the c3d_*.cpp files share. Not part of the public API (not
// installed).

#include <cmath>
#include <cstdint>
#include <cstring>
#include <limits>
#include <string>
#include <vector>

#include "io/c3d.hpp"

namespace kneesim::io::detail {

constexpr int kC3dBlock = 512;
constexpr uint8_t kC3dKey = 0x50;

enum class Proc { Intel = 84, Dec = 85, Mips = 86 };

inline const char* procName(Proc p) {
  switch (p) {
    case Proc::Intel: return "Intel";
    case Proc::Dec: return "DEC";
    case Proc::Mips: return "MIPS";
  }
  return "?";
}

// Number encodings of the three processor types.

inline float decFloatToIeee(const uint8_t* b) {
  // VAX F-floating: two little-endian 16-bit words, the first holding sign, exponent (excess
  // 128) and the high mantissa; value = 0.1mmm... x 2^(e-128), i.e. (1 + f) x 2^(e-129).
  const uint32_t bits = uint32_t(b[2]) | (uint32_t(b[3]) << 8) | (uint32_t(b[0]) << 16) | (uint32_t(b[1]) << 24);
  const int exponent = int((bits >> 23) & 0xFF);
  if (exponent == 0) return 0.0f;  // DEC zero (a set sign bit would be a "reserved operand")
  const double mantissa = 1.0 + double(bits & 0x7FFFFF) / double(1 << 23);
  const double v = std::ldexp(mantissa, exponent - 129);
  return float((bits >> 31) ? -v : v);
}

inline void ieeeToDecFloat(float f, uint8_t* out) {
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

// Reads and writes 16-bit integers and 32-bit floats as processor `proc` stores them.
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

// Trailing blanks, NULs and tabs removed.
std::string rtrimC3d(std::string s);

// ---- the parameter section (c3d_parameters.cpp)

// Decodes the parameter section of @p bytes (at out.header.parameter_block) into out.groups and
// out.parameters; InputError naming @p path for anything truncated or malformed.
void readParameterSection(const std::string& path, const std::vector<uint8_t>& bytes, const Codec& codec,
                          C3dFile& out);
// Appends the encoding of parameter @p p of group @p gid (@p last: offset 0, the section's end).
void encodeParameter(std::vector<uint8_t>& out, const Codec& c, const C3dParameter& p, int gid, bool last);
// Appends the encoding of group @p g.
void encodeGroup(std::vector<uint8_t>& out, const Codec& c, const C3dGroup& g);
// Whether name is base followed by digits only (LABELS, LABELS2, ...), ignoring case.
bool isNameWithSuffix(const std::string& name, const std::string& base);
// BASE, BASE2, BASE3, ... joined (C3D splits arrays longer than 255 entries this way).
std::vector<std::string> joinStrings(const C3dFile& f, const char* group, const std::string& base);
std::vector<double> joinValues(const C3dFile& f, const char* group, const std::string& base, bool as_unsigned = false);
// The first value of GROUP:NAME, or @p fallback when absent or empty.
double firstValue(const C3dFile& f, const char* group, const char* name, double fallback, bool as_unsigned = false);
// Frame number stored as two 16-bit words (low, high) in TRIAL:ACTUAL_START_FIELD/END_FIELD.
bool trialField(const C3dFile& f, const char* name, long& out);
// @p v, a value of the parameter @p element of @p f, as a whole number in [lo, hi] (a fraction is
// dropped, as C3D readers do); an InputError naming the file and parameter otherwise. Converting
// a float parameter of 1e10 or NaN to an integer unchecked is undefined behaviour.
long toWhole(const C3dFile& f, double v, long lo, long hi, const std::string& element);
// The first value of GROUP:NAME as a whole number in [lo, hi] (toWhole), or @p fallback when the
// parameter is absent or empty.
long firstWhole(const C3dFile& f, const char* group, const char* name, long fallback, long lo, long hi,
                bool as_unsigned = false);

// ---- force platforms (c3d_plates.cpp)

// The plates FORCE_PLATFORM describes (positions converted with @p to_m; channels checked against
// the @p nch analog channels) into out.plates.
void readForcePlates(C3dFile& out, int nch, double to_m);

}  // namespace kneesim::io::detail
