#include "ik/marker_placer.hpp"

#include <gtest/gtest.h>

#include <cmath>
#include <filesystem>
#include <fstream>
#include <random>

#include "core/error.hpp"
#include "io/trc.hpp"
#include "model/osim_reader.hpp"
#include "model/osim_writer.hpp"
#include "support/test_data.hpp"

namespace kneesim::ik {
namespace {

using Eigen::Vector3d;
using model::Vec3;

// A leg: ground -Custom 6-DOF (as OpenSim's pelvis joints)-> pelvis -Gimbal (hip)-> thigh -Pin
// (knee)-> shank, with the true marker locations of the synthetic case. Markers: pelvis P1..P4,
// thigh T1..T3, shank S1..S3.
std::shared_ptr<model::Model> makeLeg() {
  auto m = std::make_shared<model::Model>();
  m->name = "leg";
  m->bodies.resize(4);
  const char* names[] = {"ground", "pelvis", "thigh", "shank"};
  for (int i = 0; i < 4; ++i) {
    m->bodies[i].name = names[i];
    m->bodies[i].mass = i == 0 ? 0.0 : 5.0;
    m->bodies[i].inertia = model::Mat3::Identity() * (i == 0 ? 0.0 : 0.05);
  }
  auto coord = [&](const std::string& n, model::MotionType t) {
    model::Coordinate c;
    c.name = n;
    c.motion_type = t;
    m->coordinates.push_back(c);
    return int(m->coordinates.size() - 1);
  };
  const auto R = model::MotionType::Rotational, T = model::MotionType::Translational;
  model::Joint free;
  free.name = "ground_pelvis";
  free.type = model::JointType::Custom;
  free.parent_body = 0;
  free.child_body = 1;
  free.coordinates = {coord("p_rz", R), coord("p_rx", R), coord("p_ry", R),
                      coord("p_tx", T), coord("p_ty", T), coord("p_tz", T)};
  const Vec3 axes[6] = {Vec3::UnitZ(), Vec3::UnitX(), Vec3::UnitY(), Vec3::UnitX(), Vec3::UnitY(), Vec3::UnitZ()};
  for (int a = 0; a < 6; ++a) {
    free.spatial[a].axis = axes[a];
    free.spatial[a].coordinates = {free.coordinates[a]};
    free.spatial[a].function = model::makeLinear(1.0, 0.0);
  }
  model::Joint hip;
  hip.name = "hip";
  hip.type = model::JointType::Gimbal;
  hip.parent_body = 1;
  hip.child_body = 2;
  hip.X_PF = model::poseFromXYZ(Vec3::Zero(), Vec3(-0.05, -0.08, 0.09));
  hip.coordinates = {coord("hip_x", R), coord("hip_y", R), coord("hip_z", R)};
  model::Joint knee;
  knee.name = "knee";
  knee.type = model::JointType::Pin;
  knee.parent_body = 2;
  knee.child_body = 3;
  knee.X_PF = model::poseFromXYZ(Vec3(0, 0, 0.1), Vec3(0, -0.4, 0));
  knee.coordinates = {coord("knee", R)};
  m->joints = {free, hip, knee};
  m->markers = {{"P1", 1, Vec3(0.05, 0.01, 0.12), false},   {"P2", 1, Vec3(0.05, 0.0, -0.12), false},
                {"P3", 1, Vec3(-0.15, 0.02, 0.03), false},  {"P4", 1, Vec3(-0.14, 0.0, -0.04), false},
                {"T1", 2, Vec3(0.04, -0.1, 0.06), false},   {"T2", 2, Vec3(0.01, -0.3, 0.07), false},
                {"T3", 2, Vec3(0.07, -0.2, 0.02), false},   {"S1", 3, Vec3(0.03, -0.1, 0.05), false},
                {"S2", 3, Vec3(0.05, -0.35, 0.02), false},  {"S3", 3, Vec3(-0.02, -0.25, 0.06), false}};
  m->finalize();
  return m;
}

// Marker positions of @p truth at random poses (noise-free), one frame per pose.
PlacerTrial synthesize(const model::ModelPtr& truth, int frames, unsigned seed) {
  sim::System sys(truth);
  auto ws = sys.createWorkspace();
  std::mt19937 rng(seed);
  std::uniform_real_distribution<double> u(-1, 1);
  PlacerTrial trial;
  trial.name = "synthetic";
  for (int f = 0; f < frames; ++f) {
    Eigen::VectorXd q(10);
    q << 0.2 * u(rng), 0.3 * u(rng), 0.2 * u(rng), u(rng), 0.9 + 0.05 * u(rng), 0.3 * u(rng),  // pelvis
        0.3 * u(rng), 0.2 * u(rng), 0.6 * u(rng),                                            // hip
        -0.6 + 0.6 * u(rng);                                                                  // knee
    sys.realizePosition(*ws, q);
    std::vector<Vector3d> obs;
    for (const auto& mk : truth->markers) obs.push_back(sys.findStationLocation(*ws, mk.body, mk.p_BM));
    trial.time.push_back(0.01 * f);
    trial.observed.push_back(obs);
  }
  return trial;
}

// The model with markers moved by known offsets: 18-25 mm in varied directions.
std::shared_ptr<model::Model> perturbed(const model::Model& truth, const std::vector<std::string>& which) {
  auto m = std::make_shared<model::Model>(truth);
  const Vector3d offsets[] = {Vector3d(0.015, -0.01, 0.008), Vector3d(-0.012, 0.014, -0.01),
                              Vector3d(0.006, 0.012, -0.017), Vector3d(-0.018, -0.004, 0.011)};
  int k = 0;
  for (const std::string& n : which) m->markers[m->findMarker(n)].p_BM += offsets[k++ % 4];
  return m;
}

std::vector<PlacerMarker> allMarkers(const model::Model& m, const std::vector<std::string>& fixed, double weight = 1.0) {
  std::vector<PlacerMarker> out;
  for (size_t i = 0; i < m.markers.size(); ++i) {
    PlacerMarker pm;
    pm.marker = int(i);
    pm.weight = weight;
    pm.move = std::find(fixed.begin(), fixed.end(), m.markers[i].name) == fixed.end();
    out.push_back(pm);
  }
  return out;
}

// Many poses, noise-free data, the gauge anchored by fixed markers (three on the free pelvis, two
// on the thigh against hip rotation, one on the shank against a knee-angle offset): the moved
// markers come back to their true locations, whatever IK made of the wrong ones at first.
TEST(MarkerPlacer, RecoversKnownOffsetsFromManyPoses) {
  auto truth = makeLeg();
  const std::vector<std::string> moved = {"P4", "T3", "S2", "S3"};
  auto start = perturbed(*truth, moved);
  const std::vector<std::string> fixed = {"P1", "P2", "P3", "T1", "T2", "S1"};
  MarkerPlacerOptions opt;
  opt.prior_weight = 0.0;
  opt.max_iterations = 100;
  opt.tolerance = 1e-10;
  const std::vector<PlacerTrial> trials = {synthesize(truth, 40, 11)};
  const MarkerPlacerResult r = placeMarkers(start, allMarkers(*start, fixed), {}, {}, trials, opt);
  EXPECT_TRUE(r.converged);
  std::printf("[ placer   ] %zu iterations; first pass mean RMS %.3f mm, last %.2e mm\n", r.iterations.size(),
              r.iterations.front().mean_rms * 1e3, r.iterations.back().mean_rms * 1e3);
  for (const auto& mk : truth->markers) {
    const double err = (r.model->markers[r.model->findMarker(mk.name)].p_BM - mk.p_BM).norm();
    EXPECT_LT(err, 1e-7) << mk.name;
  }
  EXPECT_GT(r.iterations.front().mean_rms, 1e-3);  // the start really was wrong
  EXPECT_LT(r.trial_mean_rms[0], 1e-7);
  for (const PlacedMarkerReport& m : r.markers) EXPECT_LT(m.rms_error, 1e-7) << m.name;
}

// OpenSim's static placement: one frame; every movable marker ends exactly where it was measured
// in the pose IK found (with the fixed pelvis markers defining it).
TEST(MarkerPlacer, OneStaticFramePutsMarkersOnTheMeasurements) {
  auto truth = makeLeg();
  auto start = perturbed(*truth, {"T1", "T2", "T3", "S1", "S2", "S3"});
  const std::vector<PlacerTrial> trials = {synthesize(truth, 1, 5)};
  MarkerPlacerOptions opt;
  opt.prior_weight = 0.0;
  opt.tolerance = 1e-8;  // the second pass finds the same pose to IK's precision
  const MarkerPlacerResult r = placeMarkers(start, allMarkers(*start, {"P1", "P2", "P3", "P4"}), {}, {}, trials, opt);
  EXPECT_TRUE(r.converged);
  // A few passes, not one: the first pose is a compromise with the wrong leg markers, so the
  // fixed pelvis markers pull the second pose away from it, and the leg markers follow.
  EXPECT_LE(r.iterations.size(), 12u);
  EXPECT_GT(r.iterations.front().mean_rms, 1e-2);
  EXPECT_LT(r.trial_mean_rms[0], 1e-9);
  sim::System sys(r.model);
  auto ws = sys.createWorkspace();
  sys.realizePosition(*ws, r.poses[0][0]);
  for (size_t i = 0; i < r.model->markers.size(); ++i) {
    const auto& mk = r.model->markers[i];
    EXPECT_LT((sys.findStationLocation(*ws, mk.body, mk.p_BM) - trials[0].observed[0][i]).norm(), 1e-9) << mk.name;
  }
}

// The prior and the movement limit, in closed form: with the moved markers not steering IK
// (weight 0) the poses are exact, so each marker lands at (N x_true + mu p0) / (N + mu): half way
// for mu = N; and a limit shorter than that stops it on the segment toward the truth.
TEST(MarkerPlacer, PriorAndMovementLimitInClosedForm) {
  auto truth = makeLeg();
  const std::vector<std::string> moved = {"T3", "S2"};
  auto start = perturbed(*truth, moved);
  const int N = 20;
  const std::vector<PlacerTrial> trials = {synthesize(truth, N, 3)};
  auto markers = allMarkers(*start, {"P1", "P2", "P3", "P4", "T1", "T2", "S1", "S3"});
  for (auto& pm : markers)
    if (pm.move) pm.weight = 0.0;
  MarkerPlacerOptions opt;
  opt.prior_weight = N;
  opt.tolerance = 1e-12;
  const MarkerPlacerResult half = placeMarkers(start, markers, {}, {}, trials, opt);
  for (const std::string& n : moved) {
    const Vector3d t = truth->markers[truth->findMarker(n)].p_BM, s = start->markers[start->findMarker(n)].p_BM;
    EXPECT_LT((half.model->markers[half.model->findMarker(n)].p_BM - 0.5 * (t + s)).norm(), 1e-10) << n;
  }
  opt.prior_weight = 0.0;
  opt.max_marker_movement = 0.005;
  const MarkerPlacerResult limited = placeMarkers(start, markers, {}, {}, trials, opt);
  for (const std::string& n : moved) {
    const Vector3d t = truth->markers[truth->findMarker(n)].p_BM, s = start->markers[start->findMarker(n)].p_BM;
    const Vector3d p = limited.model->markers[limited.model->findMarker(n)].p_BM;
    EXPECT_NEAR((p - s).norm(), 0.005, 1e-12) << n;
    EXPECT_LT(((p - s).normalized() - (t - s).normalized()).norm(), 1e-9) << n;
  }
  for (const auto& m : limited.markers) EXPECT_EQ(m.clamped, m.name == "T3" || m.name == "S2") << m.name;
}

// A marker with a placeholder location (the body origin) and no prior is placed from the data
// alone, even when the other markers have a strong prior; it does not steer the first IK pass.
TEST(MarkerPlacer, UnplacedMarkerIsPlacedFromDataAlone) {
  auto truth = makeLeg();
  auto start = std::make_shared<model::Model>(*truth);
  start->markers[start->findMarker("S3")].p_BM = Vec3::Zero();
  auto markers = allMarkers(*start, {});
  markers[start->findMarker("S3")].unplaced = true;
  MarkerPlacerOptions opt;
  opt.prior_weight = 1e6;
  opt.tolerance = 1e-12;
  const MarkerPlacerResult r = placeMarkers(start, markers, {}, {}, {synthesize(truth, 10, 8)}, opt);
  EXPECT_LT((r.model->markers[r.model->findMarker("S3")].p_BM - truth->markers[truth->findMarker("S3")].p_BM).norm(),
            1e-9);
  EXPECT_LT(r.iterations.front().mean_rms, 1e-9);  // S3 at the origin did not disturb the first pass
}

// The setup file end to end: model and TRC written to disk, two trials (one with a time range
// and a stride), fixed and unplaced markers from the file, outputs written.
TEST(MarkerPlacer, SetupFileEndToEnd) {
  auto truth = makeLeg();
  auto start = perturbed(*truth, {"T3", "S2"});
  start->markers[start->findMarker("S3")].p_BM = Vec3::Zero();
  const std::string dir = test::scratchDir("marker_placer_setup");
  model::writeOsim(dir + "/leg.osim", *start);
  const PlacerTrial trial = synthesize(truth, 30, 21);
  io::MarkerTable tab;
  tab.resize(30, int(truth->markers.size()));
  tab.rate = 100;
  for (int f = 0; f < 30; ++f) {
    tab.time[f] = trial.time[f];
    tab.frame_numbers[f] = f + 1;
    for (size_t i = 0; i < truth->markers.size(); ++i) tab.updPosition(f, int(i)) = trial.observed[f][i];
  }
  for (size_t i = 0; i < truth->markers.size(); ++i) tab.labels[i] = truth->markers[i].name;
  tab.updPosition(4, int(truth->findMarker("S2"))).setConstant(std::numeric_limits<double>::quiet_NaN());  // a gap
  io::writeTrc(dir + "/trial.trc", tab, "mm");
  std::ofstream(dir + "/placer.xml") << R"(<?xml version="1.0"?>
<MarkerPlacer name="leg">
  <model_file>leg.osim</model_file>
  <IKTaskSet>
    <objects>
      <IKMarkerTask name="P1"><weight>1</weight></IKMarkerTask>
      <IKMarkerTask name="P2"><weight>1</weight></IKMarkerTask>
      <IKMarkerTask name="P3"><weight>1</weight></IKMarkerTask>
      <IKMarkerTask name="P4"><weight>1</weight></IKMarkerTask>
      <IKMarkerTask name="T1"><weight>1</weight></IKMarkerTask>
      <IKMarkerTask name="T2"><weight>1</weight></IKMarkerTask>
      <IKMarkerTask name="T3"><weight>1</weight></IKMarkerTask>
      <IKMarkerTask name="S1"><weight>1</weight></IKMarkerTask>
      <IKMarkerTask name="S2"><weight>1</weight></IKMarkerTask>
      <IKMarkerTask name="S3"><weight>1</weight></IKMarkerTask>
    </objects>
  </IKTaskSet>
  <MarkerPlacerTrialSet>
    <objects>
      <MarkerPlacerTrial name="first"><marker_file>trial.trc</marker_file><time_range>0 0.145</time_range><frame_stride>2</frame_stride></MarkerPlacerTrial>
      <MarkerPlacerTrial name="second"><marker_file>trial.trc</marker_file><time_range>0.15 1</time_range></MarkerPlacerTrial>
    </objects>
  </MarkerPlacerTrialSet>
  <unplaced_markers>S3</unplaced_markers>
  <fixed_markers>P1 P2 P3 P4 T1 T2 S1</fixed_markers>
  <prior_weight>0</prior_weight>
  <max_marker_movement>-1</max_marker_movement>
  <max_iterations>100</max_iterations>
  <tolerance>1e-10</tolerance>
  <output_model_file>leg_placed.osim</output_model_file>
  <output_marker_file>placed.csv</output_marker_file>
  <output_motion_file>first.mot</output_motion_file>
</MarkerPlacer>
)";
  const MarkerPlacerSetup setup = readMarkerPlacerSetup(dir + "/placer.xml");
  ASSERT_EQ(setup.trials.size(), 2u);
  EXPECT_EQ(setup.trials[0].frame_stride, 2);
  const MarkerPlacerResult r = runMarkerPlacer(setup);
  EXPECT_EQ(r.poses[0].size(), 8u);   // frames 0..14 (t <= 0.145), every second one
  EXPECT_EQ(r.poses[1].size(), 15u);  // frames 15..29
  model::ModelPtr placed = model::readOsim(dir + "/leg_placed.osim");
  for (const auto& mk : truth->markers)
    EXPECT_LT((placed->markers[placed->findMarker(mk.name)].p_BM - mk.p_BM).norm(), 2e-6) << mk.name;  // TRC in mm, 6 decimals
  EXPECT_TRUE(std::filesystem::exists(dir + "/placed.csv"));
  EXPECT_TRUE(std::filesystem::exists(dir + "/first.mot"));
  std::ostringstream os;
  printMarkerPlacerSummary(r, os);
  EXPECT_NE(os.str().find("S3"), std::string::npos);
}

TEST(MarkerPlacer, BadSetupsGiveOneLineErrorsAndNoOutput) {
  auto truth = makeLeg();
  const std::string dir = test::scratchDir("marker_placer_bad");
  model::writeOsim(dir + "/leg.osim", *truth);
  io::MarkerTable tab;
  tab.resize(2, 1);
  tab.labels[0] = "T1";
  tab.time = {0.0, 0.01};
  tab.frame_numbers = {1, 2};
  tab.rate = 100;
  tab.updPosition(0, 0) = Vector3d(0.1, 0.5, 0.1);
  tab.updPosition(1, 0) = Vector3d(0.1, 0.5, 0.1);
  io::writeTrc(dir + "/t.trc", tab, "mm");
  auto expectError = [&](const std::string& body, const std::string& needle) {
    std::ofstream(dir + "/s.xml") << "<MarkerPlacer>" << body << "</MarkerPlacer>";
    try {
      runMarkerPlacer(readMarkerPlacerSetup(dir + "/s.xml"));
      ADD_FAILURE() << "no error for " << body;
    } catch (const InputError& e) {
      EXPECT_NE(std::string(e.what()).find(needle), std::string::npos) << e.what();
      EXPECT_EQ(std::string(e.what()).find('\n'), std::string::npos) << e.what();
    }
    EXPECT_FALSE(std::filesystem::exists(dir + "/out.osim"));
  };
  const std::string out = "<output_model_file>out.osim</output_model_file>";
  expectError("<model_file>leg.osim</model_file><marker_file>t.trc</marker_file>", "output_model_file");
  expectError("<model_file>nope.osim</model_file><marker_file>t.trc</marker_file>" + out, "model file not found");
  expectError("<model_file>leg.osim</model_file><marker_file>none.trc</marker_file>" + out, "marker file not found");
  expectError("<model_file>leg.osim</model_file><marker_file>t.trc</marker_file><fixed_markers>X9</fixed_markers>" + out,
              "unknown marker 'X9'");
  expectError("<model_file>leg.osim</model_file><marker_file>t.trc</marker_file><time_range>5 6</time_range>" + out,
              "holds no frame");
  expectError("<model_file>leg.osim</model_file><marker_file>t.trc</marker_file><frame_stride>0</frame_stride>" + out,
              "stride");
  expectError("<model_file>leg.osim</model_file><marker_file>t.trc</marker_file><bogus/>" + out, "unknown element <bogus>");
  expectError("<model_file>leg.osim</model_file>" + out, "expected a <marker_file>");
}

}  // namespace
}  // namespace kneesim::ik
