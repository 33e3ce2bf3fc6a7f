#pragma once
// OpenSim's ExternalLoads: forces, points of application and torques read from a .mot/.sto data
// file and applied to model bodies.
//
// What is matched (opensim-core ExternalForce.cpp, ExternalLoads.cpp):
// - Each ExternalForce takes the 3 columns whose labels start with its force_identifier (and
//   point_identifier, torque_identifier), in file order, as x, y, z.
// - The data are interpolated in time with interpolating natural cubic splines (OpenSim's
//   GCVSpline of degree 3 with error variance 0); piecewise linear for 2 or 3 rows, a constant
//   for one row.
// - The force and the torque are expressed in force_expressed_in_body, the point in
//   point_expressed_in_body; without a point the force acts at the body's origin.
// - datafile is read relative to the ExternalLoads file's folder.
// Differences on purpose: a body name the model lacks is an error (OpenSim falls back to ground
// for the two "expressed in" bodies with a warning); external_loads_model_kinematics_file and
// lowpass_cutoff_frequency_for_load_kinematics are read and reported but not used, as in OpenSim
// 4's InverseDynamicsTool, which applies points expressed in ground as they are.

#include <map>
#include <string>
#include <vector>

#include <Eigen/Core>

#include "core/error.hpp"
#include "dynamics/natural_spline.hpp"
#include "io/storage.hpp"
#include "model/model.hpp"
#include "sim/system.hpp"

namespace kneesim::dynamics {

/// One <ExternalForce> as written.
struct ExternalForceSpec {
  std::string name;
  bool applies_force = true;  ///< <appliesForce> (or the older <isDisabled> negated).
  std::string applied_to_body;
  std::string force_expressed_in_body = "ground";
  std::string point_expressed_in_body = "ground";
  std::string force_identifier;   ///< "" when the force applies only a torque.
  std::string point_identifier;   ///< "" for the body origin.
  std::string torque_identifier;  ///< "" for none.
  std::string data_source_name;
  SourceLocation where;                            ///< The <ExternalForce> element.
  std::map<std::string, SourceLocation> elements;  ///< Child element -> location, for errors.

  /// Location of child element @p tag (the force's own location if it was not written).
  SourceLocation locate(const std::string& tag) const;
};

/// An <ExternalLoads> file as written, paths resolved against its folder.
struct ExternalLoadsSpec {
  std::string file;      ///< The XML file ("" when built in code).
  std::string name;
  std::string datafile;  ///< Resolved path of the force data.
  std::string kinematics_file;            ///< external_loads_model_kinematics_file ("" if none).
  double kinematics_cutoff_hz = -1.0;     ///< lowpass_cutoff_frequency_for_load_kinematics.
  std::vector<ExternalForceSpec> forces;
  SourceLocation datafile_where;
};

/// Reads an ExternalLoads XML file (<OpenSimDocument><ExternalLoads> or a bare <ExternalLoads>).
/// Throws InputError (file:line: element: ...) for a missing file, unknown element or force type,
/// a force without force or torque identifier, or a point without a force.
ExternalLoadsSpec readExternalLoads(const std::string& path);

/// The XML OpenSim reads for @p spec (OpenSimDocument Version 40000); datafile is written as
/// given in @p datafile_as_written.
std::string formatExternalLoads(const ExternalLoadsSpec& spec, const std::string& datafile_as_written);

/// External loads bound to a model: immutable, evaluation allocates nothing.
class ExternalLoads {
 public:
  /// Binds @p spec to @p model with force data @p data (read from spec.datafile). Throws
  /// InputError naming the setup element for a body the model lacks or an identifier that does
  /// not select exactly 3 columns, and naming the data file for NaN or non-increasing times.
  ExternalLoads(const ExternalLoadsSpec& spec, const model::Model& model, const io::Storage& data);

  /// Reads spec.datafile and binds (see above).
  ExternalLoads(const ExternalLoadsSpec& spec, const model::Model& model);

  /// Time span of the force data.
  double getStartTime() const { return t0_; }
  double getEndTime() const { return t1_; }
  const ExternalLoadsSpec& getSpec() const { return spec_; }

  /// Adds the loads at time @p t to @p F_G (one column per model body: moment about the body
  /// origin and force, in ground), using the body poses realised in @p ws.
  void addBodyForces(const sim::System& system, const sim::Workspace& ws, double t, sim::SpatialColumns& F_G) const;

  /// Force, point of application and torque of force @p i at time @p t, all in ground (point
  /// as a location in ground, which needs the poses in @p ws when expressed in a body).
  void calcForceInGround(const sim::System& system, const sim::Workspace& ws, int i, double t, Eigen::Vector3d& force,
                         Eigen::Vector3d& point, Eigen::Vector3d& torque) const;

  /// Number of ExternalForces that apply something.
  int getNumForces() const { return int(forces_.size()); }
  /// Index of the body force @p i is applied to.
  int getAppliedBody(int i) const { return forces_[i].body; }

 private:
  /// A column of force data as a function of time.
  struct Channel {
    NaturalSpline spline;
    double constant = 0.0;
    double at(double t) const { return spline.getDegree() < 0 ? constant : spline.calcValue(t); }
  };
  struct Bound {
    int body = -1, force_frame = 0, point_frame = 0;
    bool has_force = false, has_point = false, has_torque = false;
    Channel f[3], p[3], m[3];
  };
  ExternalLoadsSpec spec_;
  std::vector<Bound> forces_;
  double t0_ = 0, t1_ = 0;
};

}  // namespace kneesim::dynamics
