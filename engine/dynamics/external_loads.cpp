#include "dynamics/external_loads.hpp"

#include <cmath>
#include <filesystem>
#include <sstream>
#include <stdexcept>

#include "core/paths.hpp"
#include "core/strings.hpp"
#include "core/xml.hpp"

namespace kneesim::dynamics {

namespace fs = std::filesystem;

SourceLocation ExternalForceSpec::locate(const std::string& tag) const {
  auto it = elements.find(tag);
  return it != elements.end() ? it->second : where;
}

namespace {

std::string valueOrEmpty(const xml::Node& n, const char* tag) {
  const std::string v = n.childText(tag);
  return (v == "Unassigned") ? std::string() : v;
}

ExternalForceSpec readExternalForce(const xml::Node& f) {
  static const std::set<std::string> known = {
      "appliesForce",       "isDisabled",       "applied_to_body",   "force_expressed_in_body",
      "point_expressed_in_body", "force_identifier", "point_identifier", "torque_identifier",
      "data_source_name"};
  xml::checkChildren(f, known);
  ExternalForceSpec s;
  s.name = f.nameAttr();
  s.where = f.where();
  for (const xml::Node& c : f.children()) s.elements[c.name()] = c.where();
  s.applies_force = f.childBool("appliesForce", true);
  if (f.child("isDisabled") && f.childBool("isDisabled", false)) s.applies_force = false;
  s.applied_to_body = valueOrEmpty(f, "applied_to_body");
  if (s.applied_to_body.empty()) f.fail("missing <applied_to_body> (expected the name of a body of the model)");
  if (const std::string v = valueOrEmpty(f, "force_expressed_in_body"); !v.empty()) s.force_expressed_in_body = v;
  if (const std::string v = valueOrEmpty(f, "point_expressed_in_body"); !v.empty()) s.point_expressed_in_body = v;
  s.force_identifier = valueOrEmpty(f, "force_identifier");
  s.point_identifier = valueOrEmpty(f, "point_identifier");
  s.torque_identifier = valueOrEmpty(f, "torque_identifier");
  s.data_source_name = valueOrEmpty(f, "data_source_name");
  if (s.force_identifier.empty() && s.torque_identifier.empty())
    f.fail("expected a <force_identifier> or a <torque_identifier>, got neither");
  if (s.force_identifier.empty() && !s.point_identifier.empty())
    f.child("point_identifier").fail("expected no point without a force (force_identifier is empty), got '" +
                                     s.point_identifier + "'");
  return s;
}

}  // namespace

ExternalLoadsSpec readExternalLoads(const std::string& path) {
  if (!pathExists(path)) throw InputError({path, 0, ""}, "ExternalLoads file not found");
  auto doc = xml::Document::load(path);
  const xml::Node root = doc->root();
  const xml::Node el = root.name() == "ExternalLoads" ? root : root.child("ExternalLoads");
  if (!el) root.fail("expected an <ExternalLoads> element, got <" + root.name() + "> without one");
  xml::checkChildren(el, {"objects", "groups", "datafile", "external_loads_model_kinematics_file",
                          "lowpass_cutoff_frequency_for_load_kinematics"});
  ExternalLoadsSpec s;
  s.file = path;
  s.name = el.nameAttr();
  const std::string dir = fs::path(path).parent_path().string();
  const std::string datafile = valueOrEmpty(el, "datafile");
  if (datafile.empty()) el.fail("missing <datafile> (expected the .mot or .sto file of the force data)");
  s.datafile = xml::resolvePath(dir, datafile);
  s.datafile_where = el.child("datafile").where();
  if (const std::string k = valueOrEmpty(el, "external_loads_model_kinematics_file"); !k.empty())
    s.kinematics_file = xml::resolvePath(dir, k);
  s.kinematics_cutoff_hz = el.childDouble("lowpass_cutoff_frequency_for_load_kinematics", -1.0);
  if (const xml::Node objects = el.child("objects")) {
    for (const xml::Node& f : objects.children()) {
      if (f.name() != "ExternalForce") f.fail("unknown force type <" + f.name() + "> (expected ExternalForce)");
      s.forces.push_back(readExternalForce(f));
    }
  }
  if (s.forces.empty()) el.fail("expected at least one <ExternalForce> in <objects>, got none");
  return s;
}

std::string formatExternalLoads(const ExternalLoadsSpec& spec, const std::string& datafile_as_written) {
  std::ostringstream o;
  o << "<?xml version=\"1.0\" encoding=\"UTF-8\" ?>\n<OpenSimDocument Version=\"40000\">\n";
  o << "\t<ExternalLoads name=\"" << xml::escape(spec.name) << "\">\n\t\t<objects>\n";
  for (const ExternalForceSpec& f : spec.forces) {
    o << "\t\t\t<ExternalForce name=\"" << xml::escape(f.name) << "\">\n";
    auto el = [&](const char* tag, const std::string& v) {
      o << "\t\t\t\t<" << tag << ">" << xml::escape(v) << "</" << tag << ">\n";
    };
    el("appliesForce", f.applies_force ? "true" : "false");
    el("applied_to_body", f.applied_to_body);
    el("force_expressed_in_body", f.force_expressed_in_body);
    el("point_expressed_in_body", f.point_expressed_in_body);
    el("force_identifier", f.force_identifier);
    el("point_identifier", f.point_identifier);
    el("torque_identifier", f.torque_identifier);
    o << "\t\t\t</ExternalForce>\n";
  }
  o << "\t\t</objects>\n\t\t<groups />\n";
  o << "\t\t<datafile>" << xml::escape(datafile_as_written) << "</datafile>\n";
  o << "\t</ExternalLoads>\n</OpenSimDocument>\n";
  return o.str();
}

namespace {

/// Columns of @p data whose labels start with @p identifier (OpenSim's
/// Storage::getColumnIndicesForIdentifier), "time" excluded.
std::vector<int> findIdentifierColumns(const io::Storage& data, const std::string& identifier) {
  std::vector<int> cols;
  for (size_t i = 0; i < data.labels.size(); ++i)
    if (data.labels[i] != "time" && startsWith(data.labels[i], identifier)) cols.push_back(int(i));
  return cols;
}

int findBodyOrFail(const model::Model& model, const ExternalForceSpec& f, const char* tag, const std::string& name) {
  std::string n = name;
  if (startsWith(n, "/bodyset/")) n = n.substr(9);
  if (n == "/ground") n = "ground";
  const int b = model.findBody(n);
  if (b < 0)
    throw InputError(f.locate(tag), "expected a body of model " + (model.source_file.empty() ? model.name : model.source_file) +
                                        ", got '" + name + "'");
  return b;
}

}  // namespace

ExternalLoads::ExternalLoads(const ExternalLoadsSpec& spec, const model::Model& model)
    : ExternalLoads(spec, model, [&] {
        if (!pathExists(spec.datafile)) throw InputError(spec.datafile_where, "force data file not found: " + spec.datafile);
        return io::readStorage(spec.datafile);
      }()) {}

ExternalLoads::ExternalLoads(const ExternalLoadsSpec& spec, const model::Model& model, const io::Storage& data)
    : spec_(spec) {
  const std::string& file = spec.datafile;
  const int time_col = data.findColumn("time");
  if (time_col < 0) throw InputError({file, 0, "time"}, "expected a 'time' column, got none");
  const int nt = data.getNumRows();
  if (nt < 1) throw InputError({file, 0, ""}, "expected at least one row of force data, got none");
  std::vector<double> t(static_cast<size_t>(nt));
  for (int r = 0; r < nt; ++r) {
    t[r] = data.data(r, time_col);
    if (!std::isfinite(t[r]) || (r > 0 && !(t[r] > t[r - 1])))
      throw InputError({file, 0, "time"}, "expected strictly increasing times, got " + formatSignificant(t[r], 6) + " after " +
                                              formatSignificant(r > 0 ? t[r - 1] : 0.0, 6));
  }
  t0_ = t.front();
  t1_ = t.back();
  std::unique_ptr<NaturalSplineFitter> fitter;
  if (nt >= 4)
    fitter = std::make_unique<NaturalSplineFitter>(t, 3);
  else if (nt >= 2)
    fitter = std::make_unique<NaturalSplineFitter>(t, 1);

  auto channels = [&](const ExternalForceSpec& f, const char* tag, const std::string& identifier, Channel out[3]) {
    const std::vector<int> cols = findIdentifierColumns(data, identifier);
    if (cols.size() != 3) {
      std::vector<std::string> got;
      for (int c : cols) got.push_back(data.labels[c]);
      throw InputError(f.locate(tag), "expected 3 columns of " + file + " starting with '" + identifier + "', got " +
                                          std::to_string(cols.size()) +
                                          (got.empty() ? std::string() : " (" + join(got, ", ") + ")"));
    }
    for (int k = 0; k < 3; ++k) {
      std::vector<double> y(static_cast<size_t>(nt));
      for (int r = 0; r < nt; ++r) {
        y[r] = data.data(r, cols[k]);
        if (!std::isfinite(y[r]))
          throw InputError({file, 0, data.labels[cols[k]]},
                           "expected finite force data, got " + formatSignificant(y[r], 6) + " at t = " + formatSignificant(t[r], 6) + " s");
      }
      if (fitter)
        out[k].spline = fitter->fit(y);
      else
        out[k].constant = y[0];
    }
  };

  for (const ExternalForceSpec& f : spec.forces) {
    if (!f.applies_force) continue;
    Bound b;
    b.body = findBodyOrFail(model, f, "applied_to_body", f.applied_to_body);
    b.force_frame = findBodyOrFail(model, f, "force_expressed_in_body", f.force_expressed_in_body);
    b.has_force = !f.force_identifier.empty();
    b.has_point = !f.point_identifier.empty();
    b.has_torque = !f.torque_identifier.empty();
    if (b.has_point) b.point_frame = findBodyOrFail(model, f, "point_expressed_in_body", f.point_expressed_in_body);
    if (b.has_force) channels(f, "force_identifier", f.force_identifier, b.f);
    if (b.has_point) channels(f, "point_identifier", f.point_identifier, b.p);
    if (b.has_torque) channels(f, "torque_identifier", f.torque_identifier, b.m);
    forces_.push_back(std::move(b));
  }
}

void ExternalLoads::calcForceInGround(const sim::System& system, const sim::Workspace& ws, int i, double t,
                                      Eigen::Vector3d& force, Eigen::Vector3d& point, Eigen::Vector3d& torque) const {
  const Bound& b = forces_[i];
  const Eigen::Matrix3d R_GF =
      b.force_frame == 0 ? Eigen::Matrix3d(Eigen::Matrix3d::Identity()) : Eigen::Matrix3d(system.getBodyPose(ws, b.force_frame).linear());
  force.setZero();
  torque.setZero();
  if (b.has_force) force = R_GF * Eigen::Vector3d(b.f[0].at(t), b.f[1].at(t), b.f[2].at(t));
  if (b.has_torque) torque = R_GF * Eigen::Vector3d(b.m[0].at(t), b.m[1].at(t), b.m[2].at(t));
  if (b.has_point) {
    const Eigen::Vector3d p(b.p[0].at(t), b.p[1].at(t), b.p[2].at(t));
    point = b.point_frame == 0 ? p : Eigen::Vector3d(system.getBodyPose(ws, b.point_frame) * p);
  } else {
    point = system.getBodyPose(ws, b.body).translation();
  }
}

void ExternalLoads::addBodyForces(const sim::System& system, const sim::Workspace& ws, double t,
                                  sim::SpatialColumns& F_G) const {
  Eigen::Vector3d force, point, torque;
  for (int i = 0; i < int(forces_.size()); ++i) {
    calcForceInGround(system, ws, i, t, force, point, torque);
    const int body = forces_[i].body;
    const Eigen::Vector3d p_BP_G = point - system.getBodyPose(ws, body).translation();
    F_G.col(body).head<3>() += p_BP_G.cross(force) + torque;
    F_G.col(body).tail<3>() += force;
  }
}

}  // namespace kneesim::dynamics
