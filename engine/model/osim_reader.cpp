// Reader for OpenSim model files: the document (its format version and layout), the order in which
// its parts are read, and the sets kneesim reads past. The parts live in osim_*.cpp
// (osim_reader_internal.hpp lists them).
#include "model/osim_reader.hpp"

#include <filesystem>
#include <set>
#include <stdexcept>

#include "core/error.hpp"
#include "core/strings.hpp"
#include "core/xml.hpp"
#include "model/osim_reader_internal.hpp"

namespace kneesim::model {

namespace osim {

OsimReader::OsimReader(const xml::Document& doc, const std::string& label) : doc_(doc), label_(label) {
  folder_ = std::filesystem::path(label).parent_path().string();
}

std::shared_ptr<Model> OsimReader::read() {
  Node root = doc_.root();
  Node model_el;
  // OpenSim takes a document without a version for its oldest layout (XMLDocument: 10500).
  m_->format_version = 10500;
  if (root.name() == "OpenSimDocument") {
    if (auto v = root.attr("Version")) {
      double d;
      // A number an int holds (converting inf or 1e10 to one is undefined behaviour).
      if (!tryParseDouble(*v, d) || !(d >= 0 && truncatesToInt(d)))
        root.fail("expected a numeric Version attribute, got '" + *v + "'");
      m_->format_version = int(d);
    }
    model_el = root.requireChild("Model");
  } else if (root.name() == "Model") {
    model_el = root;  // very old files have no OpenSimDocument wrapper
  } else {
    root.fail("expected an OpenSim model (<OpenSimDocument> or <Model>), got <" + root.name() + ">");
  }
  // OpenSim 1.x kept the bodies, joints and coordinates inside a <DynamicsEngine> (SimbodyBody,
  // SimbodyJoint with a DofSet): a layout kneesim does not read, said as such rather than as a
  // missing BodySet. (Format 10600's DynamicsEngine was unwrapped by upgradeFormat10600.)
  if (!model_el.child("BodySet") && !model_el.child("Ground"))
    if (Node engine = model_el.child("DynamicsEngine"))
      engine.fail("expected the BodySet of a model of format 10901 or later, got OpenSim 1.x's <DynamicsEngine> "
                  "layout (format " + std::to_string(m_->format_version) + "), which kneesim does not read "
                  "(nor does OpenSim 4, which unwraps a DynamicsEngine only in files of format 10600)");
  m_->name = model_el.nameAttr();
  m_->source_file = label_;
  m_->gravity = model_el.childVec3("gravity", m_->gravity);
  if (Node u = model_el.child("length_units")) {
    const std::string units = toLower(u.text());
    if (!units.empty() && units != "meters" && units != "meter" && units != "m" && units != "metres")
      m_->warnings.push_back(formatLocated(u.where(), "length_units '" + u.text() +
                                                          "' ignored: OpenSim reads every length in the file as metres"));
  }

  // OpenSim 4 layouts (and the 4.0 pre-releases, 30500 on) have a JointSet or a Ground; older
  // ones nest each joint in its child body.
  const bool v4 = bool(model_el.child("JointSet")) || bool(model_el.child("Ground"));
  readBodies(model_el, v4);
  if (v4) {
    registerFrames(model_el);
    readJointSet(model_el);
    attachMeshes4();
    readFrameWrapObjects();
  } else {
    for (const auto& pj : pending_joints_) readJoint(pj.first, pj.second, /*v4=*/false);
  }
  checkTree();
  readConstraints(model_el);
  readMarkers(model_el, v4);
  readForces(model_el, v4);
  readIgnoredSets(model_el);

  try {
    m_->finalize();
  } catch (const std::invalid_argument& e) {
    throw InputError({label_, 0, ""}, e.what());
  }
  return m_;
}

void OsimReader::readIgnoredSets(const Node& model_el) {
  static const std::set<std::string> handled = {"BodySet", "JointSet", "ConstraintSet", "MarkerSet",
                                                "ForceSet"};
  static const std::set<std::string> frames = {"PhysicalOffsetFrame", "Station", "StationDefinedFrame"};
  for (const Node& s : model_el.children()) {
    const std::string tag = s.name();
    if (!endsWith(tag, "Set") || handled.count(tag)) continue;
    for (const Node& o : s.child("objects").children()) {
      if (tag == "ComponentSet" && frames.count(o.name())) continue;
      ignore(o, tag);
    }
  }
}

void OsimReader::ignore(const Node& item, const std::string& set_tag) {
  m_->ignored.push_back(classifyIgnored(item, set_tag));
}

}  // namespace osim

namespace {

// OpenSim 1.6's files (format 10600) keep the bodies (4.x-era Body elements with their joints),
// constraints, coordinates and markers in <DynamicsEngine><SimbodyEngine>, and the actuators in an
// <ActuatorSet>. OpenSim 4 reads them after moving the SimbodyEngine's children into the model and
// renaming ActuatorSet to ForceSet (Model::updateFromXMLNode, for format 10600 only); so does this.
void upgradeFormat10600(xml::Document& doc) {
  const xml::Node root = doc.root();
  if (root.name() != "OpenSimDocument") return;
  double version = 0;
  if (!tryParseDouble(root.attr("Version").value_or(""), version) || version != 10600) return;
  const xml::Node model_el = root.child("Model");
  if (!model_el) return;  // the reader names what is missing
  if (const xml::Node engine = model_el.child("DynamicsEngine")) {
    if (const xml::Node simbody = engine.child("SimbodyEngine")) doc.moveChildren(simbody, model_el);
  }
  if (const xml::Node actuators = model_el.child("ActuatorSet")) doc.rename(actuators, "ForceSet");
}

}  // namespace

ModelPtr parseOsim(const std::string& text, const std::string& label) {
  const auto doc = xml::Document::parse(text, label);
  upgradeFormat10600(*doc);
  osim::OsimReader reader(*doc, label);
  return reader.read();
}

ModelPtr readOsim(const std::string& path) { return parseOsim(readFileText(path), path); }

}  // namespace kneesim::model
