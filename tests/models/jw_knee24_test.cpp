// Regression tests of the JW 24-DOF knee model (models/jw-knee24): its structure and OpenSim 4.0
// conventions, the regeneration of the committed model from the UF model and the implant STLs,
// the frame checks that place the STLs, and the seating residual of its neutral pose and path.
#include <gtest/gtest.h>

#include <cmath>
#include <cstdio>
#include <filesystem>
#include <set>

#include "contact/condyle.hpp"
#include "contact/seating.hpp"
#include "core/xml.hpp"
#include "io/stl.hpp"
#include "model/osim_reader.hpp"
#include "sim/system.hpp"
#include "support/test_data.hpp"
#include "tool/knee_model.hpp"
#include "tool/run.hpp"

namespace kneesim {
namespace {

using Eigen::Isometry3d;
using Eigen::Vector3d;
constexpr double kDeg = M_PI / 180.0;

std::string modelPath(const std::string& f) { return test::sourcePath("models/jw-knee24/" + f); }

const std::vector<std::string> kBodies = {"ground", "pelvis", "femur", "femoral_component", "tibial_component",
                                          "tibia",  "patella", "talus", "calcaneus",         "toes"};
const std::vector<std::string> kCoordinates = {
    "pelvis_rz",     "pelvis_rx",        "pelvis_ry",       "pelvis_tx",      "pelvis_ty",     "pelvis_tz",
    "hip_flexion",   "hip_adduction",    "hip_rotation",    "knee_flexion",   "knee_adduction", "knee_rotation",
    "knee_tx",       "knee_ty",          "knee_tz",         "patfem_flexion", "patfem_adduction", "patfem_rotation",
    "patfem_tx",     "patfem_ty",        "patfem_tz",       "ankle_angle",    "subtalar_angle", "mtp_angle"};
const std::vector<std::pair<std::string, std::string>> kMarkers = {
    {"RAsis", "pelvis"},          {"LAsis", "pelvis"},           {"RPsis", "pelvis"},
    {"LPsis", "pelvis"},          {"Sacral", "pelvis"},          {"RThighSuperior", "femur"},
    {"RThighInferior", "femur"},  {"RThighLateral", "femur"},    {"RPatella", "patella"},
    {"RShankSuperior", "tibia"},  {"RShankInferior", "tibia"},   {"RShankLateral", "tibia"},
    {"RAnkleLateral", "tibia"},   {"RHeel", "calcaneus"},        {"RHindfoot", "calcaneus"},
    {"RMidfootSuperior", "calcaneus"}, {"RMidfootLateral", "calcaneus"}, {"RMidfootMedial", "calcaneus"},
    {"RToe", "toes"},             {"RToeMedial", "toes"},        {"RToeLateral", "toes"}};

// The paper's structure: 8 segments plus the two components, 24 coordinates grouped as
// ground-pelvis 6, hip 3, tibiofemoral 6, patellofemoral 6, ankle 2, toes 1; the 21 C3D markers
// of these segments; the knee's secondary coordinates coupled to its flexion.
void expectStructure(const model::Model& m) {
  ASSERT_EQ(m.bodies.size(), kBodies.size());
  for (const std::string& b : kBodies) EXPECT_GE(m.findBody(b), 0) << b;
  ASSERT_EQ(m.coordinates.size(), 24u);
  for (const std::string& c : kCoordinates) EXPECT_GE(m.findCoordinate(c), 0) << c;
  auto joint = [&](const std::string& n) -> const model::Joint& {
    const int j = m.findJoint(n);
    EXPECT_GE(j, 0) << n;
    return m.joints[std::max(j, 0)];
  };
  auto expectJoint = [&](const std::string& n, const std::string& parent, const std::string& child, size_t ncoord) {
    const model::Joint& j = joint(n);
    EXPECT_EQ(m.bodies[j.parent_body].name, parent) << n;
    EXPECT_EQ(m.bodies[j.child_body].name, child) << n;
    EXPECT_EQ(j.coordinates.size(), ncoord) << n;
    EXPECT_FALSE(j.reverse) << n;
  };
  expectJoint("ground_pelvis", "ground", "pelvis", 6);
  expectJoint("hip", "pelvis", "femur", 3);
  expectJoint("femoral_component_weld", "femur", "femoral_component", 0);
  expectJoint("knee", "femoral_component", "tibial_component", 6);
  expectJoint("tibial_component_weld", "tibial_component", "tibia", 0);
  expectJoint("patfem", "femoral_component", "patella", 6);
  expectJoint("ankle", "tibia", "talus", 1);
  expectJoint("subtalar", "talus", "calcaneus", 1);
  expectJoint("mtp", "calcaneus", "toes", 1);
  EXPECT_EQ(joint("femoral_component_weld").type, model::JointType::Weld);
  EXPECT_EQ(joint("tibial_component_weld").type, model::JointType::Weld);
  ASSERT_EQ(m.markers.size(), kMarkers.size());
  for (const auto& [name, body] : kMarkers) {
    const int k = m.findMarker(name);
    ASSERT_GE(k, 0) << name;
    EXPECT_EQ(m.bodies[m.markers[k].body].name, body) << name;
  }
  // Secondary knee coordinates follow knee_flexion; three patellar ones are locked.
  std::set<std::string> dependents;
  for (const auto& cc : m.couplers) {
    ASSERT_EQ(cc.independents.size(), 1u);
    EXPECT_EQ(m.coordinates[cc.independents[0]].name, "knee_flexion") << cc.name;
    dependents.insert(m.coordinates[cc.dependent].name);
  }
  EXPECT_EQ(dependents, (std::set<std::string>{"knee_adduction", "knee_rotation", "knee_tx", "knee_ty", "knee_tz",
                                               "patfem_flexion", "patfem_tx", "patfem_ty"}));
  for (const char* c : {"patfem_adduction", "patfem_rotation", "patfem_tz"})
    EXPECT_TRUE(m.coordinates[m.findCoordinate(c)].locked) << c;
  const model::Coordinate& kf = m.coordinates[m.findCoordinate("knee_flexion")];
  EXPECT_TRUE(kf.clamped);
  EXPECT_NEAR(kf.range_min, -20 * kDeg, 0.01 * kDeg);
  EXPECT_NEAR(kf.range_max, 140 * kDeg, 0.01 * kDeg);
  EXPECT_EQ(kf.default_value, 0.0);
  // The implant meshes sit on their bodies at the identity (the STL frames are the body frames);
  // the CT fibula, drawn in the tray frame, carries the tray-to-tibia transform.
  auto meshes = [&](const std::string& body) {
    std::vector<std::string> files;
    for (const auto& mesh : m.bodies[m.findBody(body)].meshes) {
      files.push_back(std::filesystem::path(mesh.file).filename().string());
      if (files.back() != "fibula.stl") {
        EXPECT_TRUE(mesh.X_BG.isApprox(Isometry3d::Identity(), 0.0)) << mesh.file;
      }
    }
    return files;
  };
  EXPECT_EQ(meshes("femoral_component"), std::vector<std::string>{"femoral_component.stl"});
  EXPECT_EQ(meshes("tibial_component"), (std::vector<std::string>{"tibial_tray.stl", "tibial_insert.stl"}));
  EXPECT_EQ(meshes("patella"), (std::vector<std::string>{"patellar_button.stl", "patella.stl"}));
  EXPECT_EQ(meshes("tibia"), std::vector<std::string>{"fibula.stl"});
}

TEST(JwKnee24, StructureOfTheCommittedModels) {
  for (const char* f : {"jw_knee24_generic.osim", "jw_knee24.osim"}) {
    SCOPED_TRACE(f);
    model::ModelPtr m = model::readOsim(modelPath(f));
    EXPECT_EQ(m->format_version, 40000);
    EXPECT_TRUE(m->ignored.empty());
    expectStructure(*m);
    // 24 coordinates, 8 coupled and 3 locked: IK varies 13.
    int free = 0;
    std::set<int> dep;
    for (const auto& cc : m->couplers) dep.insert(cc.dependent);
    for (size_t c = 0; c < m->coordinates.size(); ++c) free += !m->coordinates[c].locked && !dep.count(int(c));
    EXPECT_EQ(free, 13);
  }
  // The registered model is the generic one with other marker locations, nothing else.
  model::ModelPtr g = model::readOsim(modelPath("jw_knee24_generic.osim"));
  model::ModelPtr r = model::readOsim(modelPath("jw_knee24.osim"));
  for (size_t j = 0; j < g->joints.size(); ++j) {
    EXPECT_LT((g->joints[j].X_PF.matrix() - r->joints[j].X_PF.matrix()).cwiseAbs().maxCoeff(), 1e-15) << g->joints[j].name;
    EXPECT_LT((g->joints[j].X_BM.matrix() - r->joints[j].X_BM.matrix()).cwiseAbs().maxCoeff(), 1e-15) << g->joints[j].name;
  }
  for (size_t c = 0; c < g->coordinates.size(); ++c) EXPECT_EQ(g->coordinates[c].range_max, r->coordinates[c].range_max);
  int moved = 0;
  for (size_t k = 0; k < g->markers.size(); ++k) moved += (g->markers[k].p_BM - r->markers[k].p_BM).norm() > 1e-4;
  EXPECT_EQ(moved, 16);  // all but the four pelvis landmarks held fixed and RAnkleLateral (stairs only)
}

// Format-40000 conventions OpenSim 4.0's reader expects, checked on the XML itself: a JointSet
// whose joints name their own PhysicalOffsetFrames, frames and markers that name their parents by
// absolute component path, meshes on ".." (their owner), no OpenSim 3 elements.
TEST(JwKnee24, OpenSim40ConventionsInTheFile) {
  auto doc = xml::Document::load(modelPath("jw_knee24.osim"));
  const xml::Node root = doc->root();
  ASSERT_EQ(root.name(), "OpenSimDocument");
  EXPECT_EQ(root.attr("Version").value_or(""), "40000");
  const xml::Node model = root.child("Model");
  ASSERT_TRUE(model);
  for (const char* set : {"Ground", "BodySet", "JointSet", "ConstraintSet", "MarkerSet"})
    EXPECT_TRUE(model.child(set)) << set;
  int frames = 0, meshes = 0;
  for (const xml::Node& j : model.child("JointSet").child("objects").children()) {
    std::set<std::string> own;
    for (const xml::Node& f : j.child("frames").children("PhysicalOffsetFrame")) {
      own.insert(f.nameAttr());
      const std::string parent = f.child("socket_parent").text();
      EXPECT_TRUE(parent == "/ground" || parent.rfind("/bodyset/", 0) == 0) << parent;
      ++frames;
    }
    EXPECT_TRUE(own.count(j.child("socket_parent_frame").text())) << j.nameAttr();
    EXPECT_TRUE(own.count(j.child("socket_child_frame").text())) << j.nameAttr();
    EXPECT_FALSE(j.child("reverse")) << j.nameAttr();
    EXPECT_FALSE(j.child("parent_body")) << j.nameAttr();
    EXPECT_FALSE(j.child("location_in_parent")) << j.nameAttr();
  }
  EXPECT_EQ(frames, 18);
  for (const xml::Node& b : model.child("BodySet").child("objects").children("Body")) {
    EXPECT_FALSE(b.child("Joint")) << b.nameAttr();
    std::vector<xml::Node> holders = {b};
    for (const xml::Node& f : b.child("components").children("PhysicalOffsetFrame")) holders.push_back(f);
    for (const xml::Node& h : holders)
      for (const xml::Node& mesh : h.child("attached_geometry").children("Mesh")) {
        EXPECT_EQ(mesh.child("socket_frame").text(), "..");
        ++meshes;
      }
  }
  EXPECT_EQ(meshes, 6);
  for (const xml::Node& mk : model.child("MarkerSet").child("objects").children("Marker"))
    EXPECT_EQ(mk.child("socket_parent_frame").text().rfind("/bodyset/", 0), 0u) << mk.nameAttr();
  for (const xml::Node& cc : model.child("ConstraintSet").child("objects").children("CoordinateCouplerConstraint")) {
    const auto kids = cc.children();
    EXPECT_TRUE(std::any_of(kids.begin(), kids.end(), [](const xml::Node& n) {
      return n.nameAttr() == "coupled_coordinates_function";
    })) << cc.nameAttr();
  }
  // The three setups select their tools through `kneesim run`.
  EXPECT_EQ(tool::detectTool(modelPath("build_model.xml")), "knee-model");
  EXPECT_EQ(tool::detectTool(modelPath("marker_placer.xml")), "marker-placer");
  for (const char* t : {"ngait_og1", "ngait_og3", "ngait_og7", "stairupf1"})
    EXPECT_EQ(tool::detectTool(modelPath(std::string(t) + "_ik_setup.xml")), "ik") << t;
}

// The STL frames and the UF body frames agree: the UF model's own default knee pose puts the two
// STL components 0.63 mm into each other, equally on both condyles, 1.5 mm anterior and 0.6 mm
// below the seated pose and turned by 0.001 deg; the CT talus (drawn in the tray frame) sits on
// the UF ankle centre. The committed model is what build_model.xml regenerates.
TEST(JwKnee24, RegeneratesFromTheUfModelAndTheImplantFiles) {
  KNEESIM_REQUIRE_BUNDLED_DATA("kgc4-jw/model/jw_all_body_scaled.osim");
  KNEESIM_REQUIRE_DATA("kgc4-jw/implant/femoral_component.stl");
  const tool::KneeModelSetup setup = tool::readKneeModelSetup(modelPath("build_model.xml"));
  const tool::KneeModelResult r = tool::buildKneeModel(setup);
  const tool::KneeModelReport& rep = r.report;
  for (const std::string& l : rep.lines) std::printf("[ jw model ] %s\n", l.c_str());

  EXPECT_NEAR(rep.source_gap_medial, -0.633e-3, 0.005e-3);
  EXPECT_NEAR(rep.source_gap_lateral, -0.634e-3, 0.005e-3);
  EXPECT_LT(std::abs(rep.source_gap_medial - rep.source_gap_lateral), 0.01e-3);  // no tilt between the frames
  EXPECT_NEAR(rep.source_minus_seated.x(), -1.46e-3, 0.05e-3);
  EXPECT_NEAR(rep.source_minus_seated.y(), -0.60e-3, 0.05e-3);
  EXPECT_NEAR(rep.source_minus_seated.z(), 0.0, 0.05e-3);
  EXPECT_LT(rep.source_seated_angle, 0.01 * kDeg);
  EXPECT_NEAR(rep.femur_axis_flexion / kDeg, 3.36, 0.02);
  EXPECT_NEAR(rep.femur_axis_coronal / kDeg, 3.36, 0.02);
  EXPECT_LT(rep.talus_minus_ankle.norm(), 4e-3);
  EXPECT_NEAR(rep.talus_minus_ankle.y(), 0.0, 0.5e-3);
  EXPECT_NEAR(rep.fibula_top, -13.0e-3, 0.1e-3);
  EXPECT_NEAR(rep.patella_cut_offset, 0.05e-3, 0.01e-3);
  EXPECT_NEAR(rep.hinge_radius, 24.98e-3, 0.01e-3);
  // Seating: the neutral pose and every knot touch on both condyles; smoothing the hinge path
  // costs micrometres of height; the built model follows the path between the knots too.
  EXPECT_LE(std::max(std::abs(rep.neutral_gap_medial), std::abs(rep.neutral_gap_lateral)), 1e-7);
  EXPECT_LE(rep.max_knot_gap, 1e-7);
  EXPECT_LE(rep.max_smoothing_height, 5e-6);
  EXPECT_LE(rep.model_knot_gap, 1e-7);
  EXPECT_LE(rep.model_midpoint_gap, 2e-5);
  EXPECT_LE(rep.model_knot_patella_gap, 1e-8);
  EXPECT_LE(rep.model_midpoint_patella_gap, 5e-5);
  ASSERT_EQ(rep.knots.size(), 33u);
  // The femur rolls back as the knee flexes: the tibia's anterior translation in the femoral
  // frame reaches about -5 mm by 35-40 deg; the patella moves up to 5.4 mm outward at 140 deg.
  double min_tx = 1;
  for (const auto& k : rep.knots) min_tx = std::min(min_tx, k.q[3]);
  EXPECT_NEAR(min_tx, -5.1e-3, 0.2e-3);
  EXPECT_NEAR(rep.knots.back().patella_offset, 5.4e-3, 0.3e-3);

  // The same model as committed (same code: equal to round-off).
  model::ModelPtr committed = model::readOsim(modelPath("jw_knee24_generic.osim"));
  expectStructure(*r.model);
  ASSERT_EQ(committed->joints.size(), r.model->joints.size());
  for (size_t j = 0; j < committed->joints.size(); ++j) {
    const auto &a = committed->joints[j], &b = r.model->joints[j];
    EXPECT_EQ(a.name, b.name);
    EXPECT_LT((a.X_PF.matrix() - b.X_PF.matrix()).cwiseAbs().maxCoeff(), 1e-9) << a.name;
    EXPECT_LT((a.X_BM.matrix() - b.X_BM.matrix()).cwiseAbs().maxCoeff(), 1e-9) << a.name;
  }
  for (size_t c = 0; c < committed->couplers.size(); ++c)
    for (double x : {-0.3, 0.0, 0.4, 1.0, 2.2})
      EXPECT_NEAR(committed->couplers[c].function->calcValue(x), r.model->couplers[c].function->calcValue(x), 1e-9)
          << committed->couplers[c].name;
  for (size_t k = 0; k < committed->markers.size(); ++k)
    EXPECT_LT((committed->markers[k].p_BM - r.model->markers[k].p_BM).norm(), 1e-12) << committed->markers[k].name;
  for (size_t c = 0; c < committed->coordinates.size(); ++c) {
    EXPECT_NEAR(committed->coordinates[c].default_value, r.model->coordinates[c].default_value, 1e-12);
    // Knee and patellofemoral flexion ranges start at the first seated knot: round-off as the couplers.
    EXPECT_NEAR(committed->coordinates[c].range_min, r.model->coordinates[c].range_min, 1e-9);
  }
}

// The seating residual of the committed (registered) model, measured independently of the
// builder: drive it with knee_flexion alone through Simbody, read the femoral component's pose
// in the tibial component and measure each condyle's signed distance to the insert.
TEST(JwKnee24, SeatingResidualOfTheNeutralPoseAndThePath) {
  KNEESIM_REQUIRE_DATA("kgc4-jw/implant/femoral_component.stl");
  model::ModelPtr m = model::readOsim(modelPath("jw_knee24.osim"));
  const std::string dir = test::dataPath("kgc4-jw/implant/");
  io::TriangleMesh fem = io::readStl(dir + "femoral_component.stl", {1.0, true, 0.01, 0.5});
  io::TriangleMesh ins = io::readStl(dir + "tibial_insert.stl", {1.0, true, 0.01, 0.5});
  const contact::CondyleFits fits = contact::fitCondyles(fem, contact::ArticularSelection{});
  contact::Seater seater(contact::makeSeatingSetup(fem, ins, fits.both.cylinder));
  sim::System sys(m);
  auto ws = sys.createWorkspace();
  const int fc = m->findBody("femoral_component"), tc = m->findBody("tibial_component");
  const int kf = m->findCoordinate("knee_flexion");
  double worst = 0;
  for (double deg : {0.0, -7.5, 12.5, 30.0, 47.5, 60.0, 72.5, 90.0, 117.5}) {
    Eigen::VectorXd q = sys.getDefaultCoordinates();
    q[kf] = deg * kDeg;
    for (const auto& cc : m->couplers) q[cc.dependent] = cc.function->calcValue(q[kf]);
    sys.realizePosition(*ws, q);
    const Isometry3d X_TF = sys.getBodyPose(*ws, tc).inverse() * sys.getBodyPose(*ws, fc);
    double gap[2];
    Vector3d where[2];
    seater.calcGaps(X_TF, 0.05, gap, where);
    std::printf("[ jw seat  ] knee_flexion %6.1f deg: gap medial %+.2e m, lateral %+.2e m, contacts (%.1f %.1f %.1f) / "
                "(%.1f %.1f %.1f) mm\n",
                deg, gap[0], gap[1], where[0].x() * 1e3, where[0].y() * 1e3, where[0].z() * 1e3, where[1].x() * 1e3,
                where[1].y() * 1e3, where[1].z() * 1e3);
    if (deg == 0.0) {
      // The default pose is the seated neutral pose: couplers give it at zero flexion.
      const Eigen::VectorXd d = sys.getDefaultCoordinates();
      EXPECT_LE((q - d).cwiseAbs().maxCoeff(), 1e-12);
      EXPECT_LE(std::abs(gap[0]), 1e-7);
      EXPECT_LE(std::abs(gap[1]), 1e-7);
    }
    EXPECT_GT(where[0].z(), 0.015);  // medial contact on the medial dish
    EXPECT_LT(where[1].z(), -0.015);
    worst = std::max({worst, std::abs(gap[0]), std::abs(gap[1])});
  }
  EXPECT_LE(worst, 2e-5);
}

}  // namespace
}  // namespace kneesim
