// Contact-area outputs: the .sto round trip (columns, units header) and the .vtp/.pvd files read
// back as XML (counts, the distance field against MeshDistance, the contact flags).
#include <gtest/gtest.h>

#include <cmath>
#include <filesystem>
#include <fstream>
#include <sstream>

#include "contact/contact_output.hpp"
#include "contact/shapes.hpp"
#include "core/error.hpp"
#include "core/strings.hpp"
#include "core/xml.hpp"
#include "io/storage.hpp"
#include "support/test_data.hpp"

namespace kneesim::contact {
namespace {

using Eigen::Vector3d;

struct Scene {
  std::unique_ptr<ContactAreaCalculator> calc;
  ContactSeries series;
  std::vector<DistanceMapFrame> maps;
};

// A 30 x 40 mm flat insert (2 mm grid) under a 20 mm ball sinking from 1 mm above to 1 mm in.
Scene makeScene() {
  std::vector<double> xs, zs;
  test::appendNodes(xs, -0.015, 0.015, 2e-3);
  test::appendNodes(zs, -0.02, 0.02, 2e-3);
  io::TriangleMesh insert = test::makeHeightField(xs, zs, -0.008, [](double, double) { return 0.0; });
  insert.source_file = "insert.stl";
  io::TriangleMesh ball = test::makeSphere(Vector3d::Zero(), 0.02, 40, 80);
  ball.source_file = "ball.stl";
  Scene s;
  ContactAreaOptions o;
  o.extra_thresholds = {2e-3, 6e-3};
  s.calc = std::make_unique<ContactAreaCalculator>(insert, ball, o);
  auto ws = s.calc->createWorkspace();
  std::vector<double> time = {0.0, 0.1, 0.2};
  std::vector<Eigen::Isometry3d> poses;
  for (double g : {1e-3, 0.0, -1e-3}) {
    Eigen::Isometry3d X = Eigen::Isometry3d::Identity();
    X.translation() = Vector3d(0.001, 0.02 + g, 0.003);
    poses.push_back(X);
  }
  s.series = calcContactSeries(*s.calc, *ws, time, poses, {}, [&](int k, const ContactAreaWorkspace& w) {
    s.maps.push_back({time[size_t(k)], poses[size_t(k)], w.getDistances()});
  });
  return s;
}

TEST(ContactOutput, StorageRoundTripWithUnits) {
  const Scene s = makeScene();
  const std::string dir = test::scratchDir("contact_sto");
  std::vector<double> flexion = {0.1, 0.2, 0.3};
  const io::Storage st = makeContactStorage(s.series, *s.calc, "trial", {{"knee_flexion", flexion}},
                                            {{"kinematics", "test"}});
  io::writeStorage(dir + "/trial_contact.sto", st);
  const io::Storage back = io::readStorage(dir + "/trial_contact.sto");
  const std::vector<std::string> expected = {"time",       "S",          "S_medial",   "S_lateral",   "dmin",
                                             "dmin_medial", "dmin_lateral", "cx_medial", "cy_medial",   "cz_medial",
                                             "cx_lateral", "cy_lateral", "cz_lateral", "S@2mm",       "S@6mm",
                                             "dS_dt",      "dS_medial_dt", "dS_lateral_dt", "knee_flexion"};
  EXPECT_EQ(back.labels, expected);
  ASSERT_EQ(back.getNumRows(), 3);
  EXPECT_FALSE(back.in_degrees);
  for (int r = 0; r < 3; ++r) {
    EXPECT_NEAR(back.data(r, 1), s.series.frames[size_t(r)].S, 1e-8);
    EXPECT_NEAR(back.data(r, 4), s.series.frames[size_t(r)].dmin, 5e-9);  // "%.8f" above 1e-3
    EXPECT_NEAR(back.data(r, 14), s.series.frames[size_t(r)].S_extra[1], 1e-8);
    EXPECT_NEAR(back.data(r, 18), flexion[size_t(r)], 1e-8);
  }
  std::string units, threshold;
  for (const auto& [k, v] : back.header) {
    if (k == "units") units = v;
    if (k == "threshold_m") threshold = v;
  }
  EXPECT_NE(units.find("S:m^2"), std::string::npos) << units;
  EXPECT_NE(units.find("dmin:m"), std::string::npos);
  EXPECT_NE(units.find("dS_dt:m^2/s"), std::string::npos);
  EXPECT_NE(units.find("time:s"), std::string::npos);
  EXPECT_EQ(threshold, "0.004");
}

// Reads the named DataArray of a .vtp's Piece as numbers.
std::vector<double> readArray(const xml::Node& piece, const std::string& section, const std::string& name) {
  for (const xml::Node& a : piece.requireChild(section.c_str()).children("DataArray"))
    if (a.attr("Name").value_or("") == name) return a.toDoubles();
  ADD_FAILURE() << "no DataArray " << name;
  return {};
}

TEST(ContactOutput, VtpDistanceMapsAndCollection) {
  const Scene s = makeScene();
  const std::string dir = test::scratchDir("contact_vtp");
  const MeshDistance femur(s.calc->getFemur());
  writeInsertVtp(dir + "/insert_0002.vtp", *s.calc, s.maps[2], &femur);
  writeMeshVtp(dir + "/femur_0002.vtp", s.calc->getFemur(), s.maps[2].X_IF);
  writePvd(dir + "/trial.pvd", {{0.2, 0, "insert_0002.vtp"}, {0.2, 1, "femur_0002.vtp"}});

  auto doc = xml::Document::load(dir + "/insert_0002.vtp");
  const xml::Node piece = doc->root().requireChild("PolyData").requireChild("Piece");
  const io::TriangleMesh& insert = s.calc->getInsert();
  EXPECT_EQ(piece.attr("NumberOfPoints").value_or(""), std::to_string(insert.getNumVertices()));
  EXPECT_EQ(piece.attr("NumberOfPolys").value_or(""), std::to_string(insert.getNumTriangles()));
  const std::vector<double> distance = readArray(piece, "PointData", "distance");
  const std::vector<double> articular = readArray(piece, "PointData", "articular");
  const std::vector<double> contact = readArray(piece, "PointData", "contact");
  const std::vector<double> points = readArray(piece, "Points", "Points");
  const std::vector<double> offsets = readArray(piece, "Polys", "offsets");
  ASSERT_EQ(distance.size(), size_t(insert.getNumVertices()));
  ASSERT_EQ(points.size(), 3 * distance.size());
  ASSERT_EQ(offsets.size(), size_t(insert.getNumTriangles()));
  EXPECT_EQ(offsets.back(), 3.0 * insert.getNumTriangles());
  const Eigen::Isometry3d X_FI = s.maps[2].X_IF.inverse();
  int n_contact = 0, n_articular = 0;
  for (size_t v = 0; v < distance.size(); ++v) {
    const double exact = femur.calcSignedDistance(X_FI * insert.vertices[v]);
    const double clamp = s.calc->getSearchRadius();
    EXPECT_NEAR(distance[v], std::clamp(exact, -clamp, clamp), 1e-11) << v;
    EXPECT_EQ(contact[v], articular[v] != 0 && exact < 4e-3 ? 1.0 : 0.0) << v;
    n_contact += contact[v] != 0;
    n_articular += articular[v] != 0;
  }
  EXPECT_EQ(n_articular, int(s.calc->getArticularVertices().size()));
  EXPECT_GT(n_contact, 20);

  auto femur_doc = xml::Document::load(dir + "/femur_0002.vtp");
  const xml::Node fpiece = femur_doc->root().requireChild("PolyData").requireChild("Piece");
  const std::vector<double> fpoints = readArray(fpiece, "Points", "Points");
  const Eigen::Vector3d p0 = s.maps[2].X_IF * s.calc->getFemur().vertices[0];
  EXPECT_NEAR(fpoints[0], p0.x(), 1e-10);
  EXPECT_NEAR(fpoints[1], p0.y(), 1e-10);

  auto pvd = xml::Document::load(dir + "/trial.pvd");
  const auto sets = pvd->root().requireChild("Collection").children("DataSet");
  ASSERT_EQ(sets.size(), 2u);
  EXPECT_EQ(sets[1].attr("file").value_or(""), "femur_0002.vtp");
  EXPECT_EQ(sets[1].attr("part").value_or(""), "1");
}

TEST(ContactOutput, UnwritablePathIsAnInputErrorAndLeavesNoFile) {
  const Scene s = makeScene();
  const std::string dir = test::scratchDir("contact_vtp_bad");
  const std::string blocker = dir + "/not_a_folder";
  { std::ofstream(blocker) << "x"; }
  EXPECT_THROW(writeInsertVtp(blocker + "/insert.vtp", *s.calc, s.maps[0]), InputError);
  EXPECT_FALSE(std::filesystem::exists(blocker + "/insert.vtp"));
}

}  // namespace
}  // namespace kneesim::contact
