// Reading the knee model builder's setup file (<KneeModelTool>): the source model and implant
// files, the flexion knots and smoothing, the lab axes, the markers and the coordinate ranges.

#include <algorithm>
#include <cmath>
#include <set>

#include "core/error.hpp"
#include "core/strings.hpp"
#include "core/xml.hpp"
#include "tool/knee_model.hpp"
#include "tool/knee_model_detail.hpp"

namespace kneesim::tool {

using detail::kDeg;
using detail::kKneeModelBodyNames;
using Eigen::Matrix3d;

namespace {

// "-x z y": the lab direction of each model axis.
Matrix3d parseLabAxes(const xml::Node& n) {
  const std::vector<std::string> words = n.toWords();
  if (words.size() != 3) n.fail("expected three lab axes such as '-x z y', got '" + n.text() + "'");
  Matrix3d R = Matrix3d::Zero();
  for (int k = 0; k < 3; ++k) {
    std::string w = toLower(words[k]);
    double sign = 1;
    if (!w.empty() && (w[0] == '-' || w[0] == '+')) {
      sign = w[0] == '-' ? -1 : 1;
      w = w.substr(1);
    }
    if (w.size() != 1 || w[0] < 'x' || w[0] > 'z') n.fail("expected an axis x, y or z with an optional sign, got '" + words[k] + "'");
    R(w[0] - 'x', k) = sign;
  }
  if (std::abs(R.determinant() - 1.0) > 1e-12)
    n.fail("expected a right-handed set of lab axes, got '" + n.text() + "'");
  return R;
}

}  // namespace

KneeModelSetup readKneeModelSetup(const std::string& path) {
  // Named members, not a structured binding: C++17 lambdas cannot capture bindings.
  const xml::SetupFile file = xml::openSetupFile(
      path, "KneeModelTool",
      {"source_model_file", "femoral_component_file", "tibial_insert_file", "tibial_tray_file", "patellar_button_file",
       "patella_bone_file", "fibula_file", "talus_file", "output_model_file", "path_file", "neutral_flexion",
       "flexion_knots", "smoothing_window", "lab_axes", "MarkerSet", "CoordinateRanges"});
  const xml::Node& tool = file.tool;
  KneeModelSetup s;
  s.setup_file = path;
  if (!tool.nameAttr().empty()) s.name = tool.nameAttr();
  auto required = [&](const char* tag) {
    const std::string v = xml::resolvePath(file.dir, tool.requireChild(tag).text());
    if (v.empty()) tool.child(tag).fail(std::string("expected a file name in <") + tag + ">, got nothing");
    return v;
  };
  s.source_model_file = required("source_model_file");
  s.femoral_component_file = required("femoral_component_file");
  s.tibial_insert_file = required("tibial_insert_file");
  s.output_model_file = required("output_model_file");
  s.tibial_tray_file = xml::resolvePath(file.dir, tool.childText("tibial_tray_file"));
  s.patellar_button_file = required("patellar_button_file");
  s.patella_bone_file = xml::resolvePath(file.dir, tool.childText("patella_bone_file"));
  s.fibula_file = xml::resolvePath(file.dir, tool.childText("fibula_file"));
  s.talus_file = xml::resolvePath(file.dir, tool.childText("talus_file"));
  s.path_file = xml::resolvePath(file.dir, tool.childText("path_file"));
  s.neutral_flexion = tool.childDouble("neutral_flexion", 0.0) * kDeg;
  if (xml::Node k = tool.child("flexion_knots")) {
    // Each knot is a seating solve: a thousand (0.16 deg apart over the path) is far past useful.
    for (double d : k.toStepRange(1000)) s.flexion_knots.push_back(d * kDeg);
  } else {
    for (int d = -20; d <= 140; d += 5) s.flexion_knots.push_back(d * kDeg);
  }
  auto is_knot = [&](double x) {
    return std::any_of(s.flexion_knots.begin(), s.flexion_knots.end(), [&](double k) { return std::abs(k - x) < 1e-9; });
  };
  if (!is_knot(0.0) || !is_knot(s.neutral_flexion) || s.flexion_knots.size() < 4)
    tool.fail("expected at least 4 flexion knots including 0 and the neutral flexion");
  s.smoothing_window = tool.childDouble("smoothing_window", 15.0) * kDeg;
  if (!(s.smoothing_window > 0)) tool.child("smoothing_window").fail("expected a positive window in degrees");
  if (xml::Node a = tool.child("lab_axes")) s.R_lab_model = parseLabAxes(a);
  if (xml::Node ms = tool.child("MarkerSet")) {
    std::set<std::string> names;
    for (const xml::Node& mk : ms.children()) {
      if (mk.name() != "Marker") mk.fail("expected <Marker>, got <" + mk.name() + ">");
      KneeModelMarker m;
      m.name = mk.nameAttr();
      if (m.name.empty()) mk.fail("expected a name attribute on <Marker>, got none");
      if (!names.insert(m.name).second) mk.fail("duplicate marker '" + m.name + "'");
      m.body = mk.requireChild("body").text();
      if (std::find(std::begin(kKneeModelBodyNames), std::end(kKneeModelBodyNames), m.body) == std::end(kKneeModelBodyNames))
        mk.child("body").fail("unknown body '" + m.body + "' (expected pelvis, femur, femoral_component, "
                              "tibial_component, tibia, patella, talus, calcaneus or toes)");
      m.source = mk.childText("source");
      s.markers.push_back(m);
    }
  }
  if (xml::Node rs = tool.child("CoordinateRanges")) {
    for (const xml::Node& r : rs.children()) {
      if (r.name() != "Range") r.fail("expected <Range name=\"coordinate\">min max</Range>, got <" + r.name() + ">");
      const std::vector<double> v = r.toDoubles();
      if (r.nameAttr().empty() || v.size() != 2 || !(v[0] < v[1]))
        r.fail("expected <Range name=\"coordinate\">min max</Range> with min < max, got '" + r.text() + "'");
      s.ranges.push_back({r.nameAttr(), {v[0], v[1]}});
    }
  }
  return s;
}

}  // namespace kneesim::tool
