#pragma once
// C3D motion-capture files (https://www.c3d.org): 3D marker trajectories, analog channels and
// force-platform descriptions in one binary file of 512-byte blocks.
//
//   block 1        header: parameter-block pointer, key 0x50, point count, analog samples per
//                  frame, first/last frame, POINT:SCALE, data start block, frame rate
//   block 2...     parameter section: groups (POINT, ANALOG, FORCE_PLATFORM, ...) and their
//                  parameters; its 4th byte names the processor (84 Intel, 85 DEC, 86 MIPS)
//   DATA_START...  frames: per frame all points (x y z residual) then all analog samples;
//                  16-bit integers scaled by POINT:SCALE, or floats when POINT:SCALE < 0
//
// Integers and floats follow the processor: Intel = little-endian IEEE, DEC = little-endian
// words with VAX F-floating floats, MIPS = big-endian IEEE.

#include <string>
#include <vector>

#include <Eigen/Core>

#include "io/marker_table.hpp"

namespace kneesim::io {

/// One parameter of a C3D file, decoded. Multi-dimensional arrays keep C3D's order: the first
/// dimension varies fastest.
struct C3dParameter {
  std::string group;        ///< Name of the group, e.g. "POINT" (as in the file, normally upper case).
  std::string name;         ///< Parameter name, e.g. "LABELS".
  std::string description;  ///< Free text stored with the parameter.
  int type = 0;             ///< -1 char, 1 byte, 2 16-bit integer, 4 float.
  std::vector<int> dims;    ///< Dimensions (empty for a scalar).
  bool locked = false;      ///< Stored with a negative name length ("locked" in C3D terms).
  std::vector<double> values;        ///< Numeric parameters: all elements (bytes unsigned, integers signed).
  std::vector<std::string> strings;  ///< Char parameters: one string per dims[0] characters, trailing blanks removed.

  /// Number of numeric elements (0 for char parameters).
  int getNumValues() const { return int(values.size()); }
  /// Element @p i read as the unsigned 16-bit integer C3D writers use above 32767 (FRAMES, USED).
  double getUnsigned(int i) const;
};

/// A parameter group.
struct C3dGroup {
  int id = 0;  ///< Positive group number used by its parameters.
  std::string name, description;
  bool locked = false;
};

/// The header block, decoded (values as stored; the reader prefers parameters where the
/// header is known to overflow).
struct C3dHeader {
  int parameter_block = 0;         ///< 1-based block of the parameter section.
  int num_points = 0;              ///< 3D points per frame.
  int analog_per_frame = 0;        ///< Analog values per 3D frame (channels x samples per frame).
  int first_frame = 0;             ///< 1-based, 16-bit.
  int last_frame = 0;              ///< 16-bit (65535 when the trial is longer).
  int max_interpolation_gap = 0;
  double scale = 0;                ///< POINT:SCALE; negative for float data.
  int data_start = 0;              ///< 1-based block of the first frame.
  int analog_samples_per_frame = 0;
  double frame_rate = 0;           ///< Hz.
};

/// Analog channels sampled at an integer multiple of the point rate.
struct AnalogTable {
  std::vector<std::string> labels, units, descriptions;  ///< One per channel.
  double rate = 0;                  ///< Hz.
  int samples_per_frame = 0;        ///< Analog samples per 3D frame.
  std::vector<double> time;         ///< s, one per sample (row).
  Eigen::MatrixXd data;             ///< Rows = samples, columns = channels; (raw - OFFSET) * SCALE * GEN_SCALE.

  /// Number of channels.
  int getNumChannels() const { return int(labels.size()); }
  /// Index of the channel labelled @p label (exact, then ignoring case), or -1.
  int findChannel(const std::string& label) const;
};

/// A force platform as FORCE_PLATFORM describes it.
struct ForcePlate {
  int type = 0;                            ///< FORCE_PLATFORM:TYPE (2 and 4 are supported by calcPlateWrench).
  Eigen::Matrix<double, 3, 4> corners_m;   ///< Corners 1..4 in the lab frame, metres (columns).
  Eigen::Vector3d origin_m;                ///< FORCE_PLATFORM:ORIGIN as stored, plate frame, metres.
  std::vector<int> channels;               ///< 0-based analog column of each plate output (Fx Fy Fz Mx My Mz).
  Eigen::Matrix<double, 6, 6> cal_matrix;  ///< CAL_MATRIX (type 4), identity when absent.
  bool has_cal_matrix = false;
};

/// Everything read from a C3D file.
struct C3dFile {
  std::string path;
  std::string processor;                   ///< "Intel", "DEC" or "MIPS".
  C3dHeader header;
  MarkerTable markers;                     ///< Points in metres, NaN where the residual is negative.
  std::vector<double> residuals;           ///< Metres, indexed like markers.positions; NaN where missing.
  AnalogTable analog;
  std::vector<ForcePlate> plates;
  int first_frame = 1;                     ///< 1-based number of the first frame (TRIAL:ACTUAL_START_FIELD if present).
  int last_frame = 0;
  std::vector<C3dGroup> groups;
  std::vector<C3dParameter> parameters;    ///< Every parameter of the file, in file order.

  /// The parameter GROUP:NAME (names compared ignoring case), or nullptr.
  const C3dParameter* findParameter(const std::string& group, const std::string& name) const;
};

/// Reads a C3D file with one bulk read. Marker positions are converted from POINT:UNITS (mm,
/// cm, m; mm if absent) to metres; analog values are scaled to their units. Labels longer than
/// one parameter (LABELS2, LABELS3, ...) are joined; unlabelled points are named "*<index>".
/// Throws InputError naming the file and what was expected vs found for: a missing file, a bad
/// key byte, a parameter section pointing past the end of the file, an unknown processor, a
/// malformed parameter, an unknown POINT:UNITS, force-plate channels outside the analog
/// channels, or data shorter than frames x (points + analog) (truncated).
C3dFile readC3d(const std::string& path);

/// How writeC3d encodes a file.
struct C3dWriteOptions {
  std::string processor = "Intel";  ///< "Intel", "DEC" or "MIPS".
  bool float_format = true;         ///< Floats (POINT:SCALE < 0) or 16-bit integers.
  /// Length per integer count for integer files, and the residual unit for both, in `units`.
  double point_scale = 0.1;
  std::string units = "mm";         ///< POINT:UNITS written; positions are converted from metres.
};

/// Writes @p c3d as a C3D file (atomically): header, the parameters of c3d.parameters that are
/// not regenerated, and POINT, ANALOG, FORCE_PLATFORM and TRIAL parameters regenerated from
/// markers, analog and plates; then the frames. Intended for tests and exports; analog
/// channels of integer files get a per-channel SCALE that covers their range. Throws
/// InputError if a coordinate does not fit the integer range or the output cannot be written.
void writeC3d(const std::string& path, const C3dFile& c3d, const C3dWriteOptions& options = {});

/// Ground reaction of one force plate in the lab frame, one entry per analog sample.
struct PlateWrench {
  std::vector<Eigen::Vector3d> force;        ///< N, as the plate reports it (R * [Fx Fy Fz]); upward for a standing subject.
  std::vector<Eigen::Vector3d> cop;          ///< Centre of pressure on the plate surface, m; NaN when |Fz| < threshold.
  std::vector<Eigen::Vector3d> free_moment;  ///< Moment about the plate normal at the COP, N m; NaN with the COP.
};

/// Computes force, centre of pressure and free moment of plate @p plate (0-based) for type 2
/// (Fx Fy Fz Mx My Mz about the sensor origin) and type 4 (the same after CAL_MATRIX) plates.
/// The plate frame comes from the corners (x from corner 2 to 1, y from corner 4 to 1, z = x
/// cross y); ORIGIN is the sensor origin to surface centre offset in that frame (a positive z
/// is taken as the opposite convention and negated, as common readers do). Force units N
/// (or kN, lbf), moment units N mm (or N m); other units are an InputError. COP and free moment
/// are NaN where the plate-normal force is below @p min_normal_force (N).
PlateWrench calcPlateWrench(const C3dFile& c3d, int plate, double min_normal_force = 10.0);

}  // namespace kneesim::io
