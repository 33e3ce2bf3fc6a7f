// The IK tool: OpenSim setup files, runs over marker files, outputs, and every kind of bad input.
#include "ik/tool.hpp"

#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include <cmath>
#include <filesystem>
#include <fstream>
#include <iterator>
#include <map>
#include <sstream>

#include "io/c3d.hpp"
#include "io/motion_compare.hpp"
#include "io/storage.hpp"
#include "io/trc.hpp"
#include "model/kinematics.hpp"
#include "model/osim_reader.hpp"
#include "support/test_data.hpp"

namespace kneesim::ik {
namespace {

namespace fs = std::filesystem;
using ::testing::HasSubstr;
using model::Vec3;

std::string slurp(const std::string& path) {
  std::ifstream in(path, std::ios::binary);
  return std::string(std::istreambuf_iterator<char>(in), std::istreambuf_iterator<char>());
}

void spit(const std::string& path, const std::string& text) {
  std::ofstream out(path, std::ios::binary);
  out << text;
}

/// Replaces the first occurrence of @p from in @p text (which must contain it).
std::string replaced(std::string text, const std::string& from, const std::string& to) {
  const size_t at = text.find(from);
  EXPECT_NE(at, std::string::npos) << from;
  if (at != std::string::npos) text.replace(at, from.size(), to);
  return text;
}

/// Files in @p dir and below, relative names, sorted.
std::vector<std::string> listFiles(const std::string& dir) {
  std::vector<std::string> out;
  if (!fs::exists(dir)) return out;
  for (const auto& e : fs::recursive_directory_iterator(dir))
    if (e.is_regular_file()) out.push_back(fs::relative(e.path(), dir).string());
  std::sort(out.begin(), out.end());
  return out;
}

/// Converts a motion row (degrees for rotational coordinates, as written) to coordinates in SI.
Eigen::VectorXd coordinatesOfRow(const model::Model& m, const io::Storage& motion, int row) {
  Eigen::VectorXd q(m.coordinates.size());
  for (size_t c = 0; c < m.coordinates.size(); ++c) {
    const int col = motion.findColumn(m.coordinates[c].name);
    EXPECT_GE(col, 0) << m.coordinates[c].name;
    const bool rot = m.coordinates[c].motion_type == model::MotionType::Rotational;
    q[c] = motion.data(row, col) * (rot && motion.in_degrees ? M_PI / 180.0 : 1.0);
  }
  return q;
}

// --------------------------------------------------------------------------------------------
// The chain fixture: tests/model/fixtures/chain40000.osim (pin, slider, gimbal, universal and a
// spline CustomJoint with a coupler) moving along a known smooth path, markers written to a TRC.

struct ChainCase {
  std::string dir;       ///< Scratch folder holding the setup, model and marker file.
  std::string setup;     ///< Path of the setup file.
  std::vector<Eigen::VectorXd> truth;  ///< Coordinates of each frame.
  io::MarkerTable markers;             ///< What chain.trc holds (metres).
};

Eigen::VectorXd chainPose(const model::Model& m, int f) {
  Eigen::VectorXd q(m.coordinates.size());
  for (size_t c = 0; c < m.coordinates.size(); ++c) q[c] = 0.3 * std::sin(0.15 * f + 0.7 * double(c)) + 0.1;
  q[m.findCoordinate("q_c_tz")] = q[m.findCoordinate("q_slide")] + 0.02;  // the coupler
  return q;
}

ChainCase makeChainCase(const std::string& name) {
  ChainCase c;
  c.dir = test::scratchDir("iktool_" + name);
  fs::copy_file(test::sourcePath("tests/model/fixtures/chain40000.osim"), c.dir + "/chain40000.osim");
  fs::create_directories(c.dir + "/Geometry");
  fs::copy_file(test::sourcePath("tests/model/fixtures/Geometry/box.stl"), c.dir + "/Geometry/box.stl");
  c.setup = c.dir + "/chain_setup.xml";
  fs::copy_file(test::fixturePath("fixtures/chain_setup.xml"), c.setup);
  auto model = model::readOsim(c.dir + "/chain40000.osim");
  sim::System sys(model);
  auto ws = sys.createWorkspace();
  io::MarkerTable& t = c.markers;
  t.resize(20, int(model->markers.size()));
  t.rate = 100;
  for (size_t i = 0; i < model->markers.size(); ++i) t.labels[i] = model->markers[i].name;
  for (int f = 0; f < 20; ++f) {
    t.time[f] = f / 100.0;
    t.frame_numbers[f] = f + 1;
    c.truth.push_back(chainPose(*model, f));
    sys.realizePosition(*ws, c.truth.back());
    for (size_t i = 0; i < model->markers.size(); ++i)
      t.updPosition(f, int(i)) = sys.findStationLocation(*ws, model->markers[i].body, model->markers[i].p_BM);
  }
  io::writeTrc(c.dir + "/chain.trc", t, "mm");
  return c;
}

IkReport runSetup(const std::string& setup) { return runIk(readIkSetup(setup)); }

// fixtures/chain.trc (input of the command-line test) is this generated motion.
TEST(IkTool, FixtureMarkerFileIsTheGeneratedChainMotion) {
  const ChainCase c = makeChainCase("fixture");
  const io::MarkerTable fixture = io::readTrc(test::fixturePath("fixtures/chain.trc"));
  ASSERT_EQ(fixture.getNumFrames(), c.markers.getNumFrames());
  ASSERT_EQ(fixture.labels, c.markers.labels);
  for (size_t k = 0; k < fixture.positions.size(); ++k)
    EXPECT_LT((fixture.positions[k] - c.markers.positions[k]).norm(), 1e-9);
}

/// Runs @p setup expecting an InputError; checks it is one line and returns it.
std::string errorOf(const std::string& setup) {
  try {
    runSetup(setup);
  } catch (const InputError& e) {
    const std::string w = e.what();
    EXPECT_EQ(w.find('\n'), std::string::npos) << w;
    return w;
  }
  ADD_FAILURE() << "expected an InputError from " << setup;
  return "";
}

/// The run left nothing behind: no results folder content, no temporary file anywhere.
void expectNoOutputs(const ChainCase& c) {
  EXPECT_TRUE(listFiles(c.dir + "/results").empty()) << "left behind: " << ::testing::PrintToString(listFiles(c.dir + "/results"));
  for (const std::string& f : listFiles(c.dir)) EXPECT_EQ(f.find(".tmp"), std::string::npos) << f;
}

TEST(IkTool, ReadsTheSetupAsOpenSimDoes) {
  const ChainCase c = makeChainCase("read");
  const IkSetup s = readIkSetup(c.setup);
  EXPECT_EQ(s.name, "chain");
  EXPECT_EQ(s.model_file, c.dir + "/chain40000.osim");  // relative to the setup file
  EXPECT_EQ(s.marker_file, c.dir + "/chain.trc");
  EXPECT_EQ(s.output_motion_file, c.dir + "/results/chain_ik.mot");
  EXPECT_EQ(s.results_directory, c.dir + "/results");
  EXPECT_EQ(s.coordinate_file, "");  // "Unassigned"
  EXPECT_TRUE(std::isinf(s.constraint_weight));
  EXPECT_EQ(s.accuracy, 1e-8);
  EXPECT_EQ(s.solver.step_tolerance, 1e-8);
  EXPECT_EQ(s.time_start, 0);
  EXPECT_EQ(s.time_end, 0.19);
  ASSERT_EQ(s.tasks.size(), 7u);
  EXPECT_EQ(s.tasks[1].name, "mA2");
  EXPECT_EQ(s.tasks[1].weight, 2);
  EXPECT_EQ(s.tasks[6].kind, TaskSpec::Kind::Coordinate);
  EXPECT_FALSE(s.tasks[6].apply);
  EXPECT_TRUE(s.report_errors);
  EXPECT_TRUE(s.report_marker_locations);
  EXPECT_EQ(s.locate("time_range").line, 46);
  // OpenSim's misspelled root tag and a task set in its own file.
  const std::string text = slurp(c.setup);
  std::string misspelled = replaced(replaced(text, "<InverseKinematicsTool", "<InverseKinemtaticsTool"),
                                    "</InverseKinematicsTool>", "</InverseKinemtaticsTool>");
  const size_t a = misspelled.find("<IKTaskSet"), b = misspelled.find("</IKTaskSet>") + 12;
  spit(c.dir + "/tasks.xml", "<OpenSimDocument Version=\"40000\">" + misspelled.substr(a, b - a) + "</OpenSimDocument>");
  misspelled.replace(a, b - a, "<IKTaskSet file=\"tasks.xml\"/>");
  spit(c.dir + "/misspelled.xml", misspelled);
  const IkSetup m = readIkSetup(c.dir + "/misspelled.xml");
  EXPECT_EQ(m.name, "chain");
  EXPECT_EQ(m.tasks.size(), 7u);
}

TEST(IkTool, RecoversTheChainMotionAndWritesEveryOutputTogether) {
  const ChainCase c = makeChainCase("good");
  const IkReport r = runSetup(c.setup);
  EXPECT_EQ(r.frames_total, 20);
  EXPECT_EQ(r.frames_solved, 20);
  EXPECT_LT(r.max_error, 1e-7);
  EXPECT_EQ(r.loose_name_matches, 0);
  EXPECT_EQ(listFiles(c.dir + "/results"),
            (std::vector<std::string>{"chain_ik.mot", "chain_ik_marker_error_summary.csv", "chain_ik_marker_error_table.sto",
                                      "chain_ik_marker_errors.sto", "chain_ik_model_marker_locations.sto"}));
  EXPECT_EQ(r.outputs.size(), 5u);
  // The missing mesh of the fixture is a warning, not an error: IK does not need meshes.
  ASSERT_FALSE(r.warnings.empty());
  EXPECT_THAT(r.warnings[0], HasSubstr("1 mesh file not found (missing_floor.vtp)"));

  // The motion: rotational coordinates in degrees, the known path recovered.
  const auto model = model::readOsim(c.dir + "/chain40000.osim");
  const io::Storage mot = io::readStorage(c.dir + "/results/chain_ik.mot");
  EXPECT_TRUE(mot.in_degrees);
  ASSERT_EQ(mot.getNumRows(), 20);
  EXPECT_EQ(mot.labels.front(), "time");
  EXPECT_NEAR(mot.data(7, mot.findColumn("q_pin")), c.truth[7][0] * 180 / M_PI, 1e-5);
  EXPECT_NEAR(mot.data(7, mot.findColumn("q_slide")), c.truth[7][1], 1e-7);  // metres stay metres
  // Six markers leave the gimbal-universal-custom end of the chain nearly free to turn about one
  // axis, so the coordinates there are not unique; the markers are, and the pin, the slider and
  // the coupled translation are determined. The written motion is checked through the model
  // tests' own forward kinematics (plain Eigen, no Simbody).
  for (int f = 0; f < 20; ++f) {
    EXPECT_NEAR(mot.data(f, 0), f / 100.0, 1e-12);
    const Eigen::VectorXd q = coordinatesOfRow(*model, mot, f);
    const std::vector<double> qv(q.data(), q.data() + q.size());
    for (size_t i = 0; i < model->markers.size(); ++i)
      EXPECT_LT((test::markerInGround(*model, qv, model->markers[i].name) - c.markers.getPosition(f, int(i))).norm(), 1e-7)
          << "frame " << f << " " << model->markers[i].name;
    for (const char* name : {"q_pin", "q_slide", "q_c_tz"}) {
      const int k = model->findCoordinate(name);
      EXPECT_NEAR(q[k], c.truth[f][k], 1e-6) << "frame " << f << " " << name;
    }
  }
  // Per-frame errors, the per-marker table (opensim-core#2748), the per-marker summary and the
  // model marker locations.
  const io::Storage err = io::readStorage(c.dir + "/results/chain_ik_marker_errors.sto");
  EXPECT_EQ(err.labels, (std::vector<std::string>{"time", "total_squared_error", "marker_error_RMS",
                                                  "marker_error_max", "markers_used"}));
  EXPECT_EQ(err.data(3, 4), 6);
  EXPECT_LT(err.data.col(3).maxCoeff(), 1e-7);
  const io::Storage table = io::readStorage(c.dir + "/results/chain_ik_marker_error_table.sto");
  EXPECT_EQ(table.labels, (std::vector<std::string>{"time", "mA", "mA2", "mB", "mC", "mD", "mE"}));
  const std::string csv = slurp(c.dir + "/results/chain_ik_marker_error_summary.csv");
  EXPECT_THAT(csv, HasSubstr("marker,data_label,frames,mean_mm,rms_mm,max_mm\nmA,mA,20,"));
  const io::Storage loc = io::readStorage(c.dir + "/results/chain_ik_model_marker_locations.sto");
  ASSERT_EQ(loc.labels.size(), 1u + 3 * 6);
  EXPECT_EQ(loc.labels[4], "mA2_tx");
  EXPECT_NEAR(loc.data(11, 4), c.markers.getPosition(11, 1).x(), 1e-7);
}

// A larger workflow stages IK's outputs in its own set: nothing is written until it commits, and
// the report carries the motion as it will be written.
TEST(IkTool, OutputsCanBeStagedInAnotherSet) {
  const ChainCase c = makeChainCase("staged");
  AtomicFileSet set;
  IkRunOptions o;
  o.stage = &set;
  const IkReport r = runIk(readIkSetup(c.setup), o);
  EXPECT_FALSE(fs::exists(c.dir + "/results/chain_ik.mot"));
  EXPECT_EQ(r.outputs.size(), 5u);
  EXPECT_EQ(set.getPaths().size(), 5u);
  ASSERT_EQ(r.motion.getNumRows(), 20);
  EXPECT_TRUE(r.motion.in_degrees);
  set.commit();
  const io::Storage mot = io::readStorage(c.dir + "/results/chain_ik.mot");
  EXPECT_EQ(mot.labels, r.motion.labels);
  EXPECT_NEAR((mot.data - r.motion.data).cwiseAbs().maxCoeff(), 0.0, 1e-7);  // as written (%.8f)
}

// A model and markers the caller holds in memory (the Python bindings' case): the setup's tasks
// and settings apply, its files are not read, and with write = false nothing is written.
TEST(IkTool, RunsOnAModelAndMarkersInMemoryWithoutWriting) {
  const ChainCase c = makeChainCase("memory");
  IkSetup setup = readIkSetup(c.setup);
  setup.model_file = setup.marker_file = "(not read)";
  const model::ModelPtr model = model::readOsim(c.dir + "/chain40000.osim");
  IkRunOptions o;
  o.write = false;
  const IkReport r = runIk(setup, model, c.markers, o);
  EXPECT_EQ(r.model, model);
  EXPECT_TRUE(r.outputs.empty());
  EXPECT_EQ(listFiles(c.dir + "/results"), std::vector<std::string>{});
  ASSERT_EQ(r.motion.getNumRows(), 20);
  EXPECT_LT(r.max_error, 1e-7);
  for (int f = 0; f < 20; ++f) {  // the coordinates the six markers determine (see above)
    const Eigen::VectorXd q = coordinatesOfRow(*model, r.motion, f);
    for (const char* name : {"q_pin", "q_slide", "q_c_tz"}) {
      const int k = model->findCoordinate(name);
      EXPECT_NEAR(q[k], c.truth[f][k], 1e-6) << "frame " << f << " " << name;
    }
  }
}

TEST(IkTool, TheCouplerHoldsAndAFiniteConstraintWeightIsReportedUnused) {
  const ChainCase c = makeChainCase("coupler");
  spit(c.setup, replaced(slurp(c.setup), "<constraint_weight>Infinity", "<constraint_weight>10.0"));
  const IkReport r = runSetup(c.setup);
  bool warned = false;
  for (const auto& w : r.warnings) warned = warned || w.find("constraint_weight 10 is not used") != std::string::npos;
  EXPECT_TRUE(warned);
  const auto model = model::readOsim(c.dir + "/chain40000.osim");
  sim::System sys(model);
  auto ws = sys.createWorkspace();  // couplers enabled: Simbody's own error
  const io::Storage mot = io::readStorage(c.dir + "/results/chain_ik.mot");
  for (int f = 0; f < mot.getNumRows(); ++f) {
    sys.realizePosition(*ws, coordinatesOfRow(*model, mot, f));
    EXPECT_LT(std::abs(sys.calcCouplerErrors(*ws)[0]), 1e-8);  // the file keeps 8 decimals
  }
}

TEST(IkTool, MatchesMarkerNamesIgnoringSeparatorsAndRotatesTheData) {
  ChainCase c = makeChainCase("names");
  // A Z-up laboratory: the file holds R_x(+90) p; <marker_rotation>-90 0 0 turns it back. Labels
  // written with separators and a subject prefix.
  io::MarkerTable t = c.markers;
  const Eigen::Matrix3d Rx90 = model::poseFromXYZ(Vec3(M_PI / 2, 0, 0), Vec3::Zero()).linear();
  for (auto& p : t.positions) p = Rx90 * p;
  t.labels = {"S1:m_A", "m.A2", "m B", "mC", "m-D", "m.E"};
  io::writeTrc(c.dir + "/chain.trc", t, "m");
  spit(c.setup, replaced(slurp(c.setup), "<marker_file>", "<marker_rotation>-90 0 0</marker_rotation>\n<marker_file>"));
  const IkReport r = runSetup(c.setup);
  EXPECT_EQ(r.loose_name_matches, 5);
  EXPECT_EQ(r.markers[0].data_label, "S1:m_A");
  EXPECT_EQ(r.markers[3].data_label, "mC");
  EXPECT_LT(r.max_error, 1e-7);
  // Two labels matching one name is an error that names both.
  fs::remove_all(c.dir + "/results");
  t.labels = {"m_A", "m.A", "mA2", "mB", "mC", "mD"};
  io::writeTrc(c.dir + "/chain.trc", t, "m");
  EXPECT_THAT(errorOf(c.setup), HasSubstr("IKMarkerTask[mA]: marker 'mA' matches both 'm_A' and 'm.A' of " + c.dir +
                                            "/chain.trc when separators are ignored"));
  expectNoOutputs(c);
}

// IKCoordinateTask with value_type from_file: the coordinate file (degrees) is interpolated
// linearly at the marker frames' times; a heavy weight makes the coordinate follow it.
TEST(IkTool, CoordinateTaskFollowsTheCoordinateFile) {
  const ChainCase c = makeChainCase("coordfile");
  io::Storage ref;
  ref.name = "reference";
  ref.in_degrees = true;
  ref.labels = {"time", "q_pin"};
  ref.data.resize(11, 2);
  for (int k = 0; k < 11; ++k) ref.data.row(k) << 0.02 * k, 10.0 + 2.0 * k;  // 10 deg + 100 deg/s
  io::writeStorage(c.dir + "/reference.mot", ref);
  std::string text = slurp(c.setup);
  text = replaced(text, "<coordinate_file>Unassigned", "<coordinate_file>reference.mot");
  text = replaced(text, "<apply>false</apply>\n\t\t\t\t\t<weight>1</weight>\n\t\t\t\t\t<value_type>default_value",
                  "<apply>true</apply>\n\t\t\t\t\t<weight>1e8</weight>\n\t\t\t\t\t<value_type>from_file");
  spit(c.setup, text);
  runSetup(c.setup);
  const io::Storage mot = io::readStorage(c.dir + "/results/chain_ik.mot");
  for (int f = 0; f < 20; ++f)  // t = 0.01 f: halfway between rows of the file at odd frames
    EXPECT_NEAR(mot.data(f, mot.findColumn("q_pin")), 10.0 + 100.0 * 0.01 * f, 1e-3) << "frame " << f;
  // A coordinate the file lacks.
  ref.labels = {"time", "q_other"};
  io::writeStorage(c.dir + "/reference.mot", ref);
  fs::remove_all(c.dir + "/results");
  EXPECT_THAT(errorOf(c.setup), HasSubstr("IKCoordinateTask[q_pin]: coordinate 'q_pin' is not a column of " + c.dir + "/reference.mot"));
  expectNoOutputs(c);
}

// ----------------------------------------------------------------------------- bad input

TEST(IkTool, MalformedSetupXmlNamesFileAndLine) {
  const ChainCase c = makeChainCase("malformed");
  std::string text = slurp(c.setup);
  text = replaced(text, "<weight>2</weight>", "<weight>2</wieght>");
  spit(c.setup, text);
  const std::string msg = errorOf(c.setup);
  EXPECT_THAT(msg, HasSubstr(c.setup + ":"));
  EXPECT_THAT(msg, HasSubstr("XML"));
  expectNoOutputs(c);
  // An element OpenSim's tool does not have.
  spit(c.setup, replaced(slurp(test::fixturePath("fixtures/chain_setup.xml")), "<marker_file>", "<marker_fil>x</marker_fil><marker_file>"));
  EXPECT_THAT(errorOf(c.setup), HasSubstr(c.setup + ":44: OpenSimDocument/InverseKinematicsTool[chain]/marker_fil: unknown element <marker_fil>"));
  expectNoOutputs(c);
}

TEST(IkTool, MissingModelMarkerAndTaskFilesNameTheSetupElement) {
  const ChainCase c = makeChainCase("missing");
  const std::string text = slurp(c.setup);
  spit(c.setup, replaced(text, "<model_file>chain40000.osim", "<model_file>nope.osim"));
  EXPECT_EQ(errorOf(c.setup), c.setup + ":7: OpenSimDocument/InverseKinematicsTool[chain]/model_file: model file not found: " +
                                  c.dir + "/nope.osim");
  spit(c.setup, replaced(text, "<marker_file>chain.trc", "<marker_file>nope.trc"));
  EXPECT_EQ(errorOf(c.setup), c.setup + ":44: OpenSimDocument/InverseKinematicsTool[chain]/marker_file: marker file not found: " +
                                  c.dir + "/nope.trc");
  const size_t a = text.find("<IKTaskSet"), b = text.find("</IKTaskSet>") + 12;
  spit(c.setup, std::string(text).replace(a, b - a, "<IKTaskSet file=\"nope_tasks.xml\"/>"));
  EXPECT_THAT(errorOf(c.setup), HasSubstr(c.setup + ":10: OpenSimDocument/InverseKinematicsTool[chain]/IKTaskSet: IKTaskSet file not found: " +
                                          c.dir + "/nope_tasks.xml"));
  expectNoOutputs(c);
}

TEST(IkTool, UnknownJointAndFunctionTypesInTheModelStopTheRun) {
  // The model reader's own tests cover these types in detail; here they must reach the user
  // through the tool as one line naming the model file, and leave no output.
  const ChainCase c = makeChainCase("types");
  const std::string model = slurp(c.dir + "/chain40000.osim");
  spit(c.dir + "/chain40000.osim",
       replaced(replaced(model, "<PinJoint name=\"pin\">", "<HingeJoint name=\"pin\">"), "</PinJoint>", "</HingeJoint>"));
  std::string msg = errorOf(c.setup);
  EXPECT_THAT(msg, HasSubstr(c.dir + "/chain40000.osim:"));
  EXPECT_THAT(msg, HasSubstr("HingeJoint"));
  expectNoOutputs(c);
  spit(c.dir + "/chain40000.osim",
       replaced(replaced(model, "<SimmSpline name=\"function\">", "<BezierSpline name=\"function\">"), "</SimmSpline>",
                "</BezierSpline>"));
  msg = errorOf(c.setup);
  EXPECT_THAT(msg, HasSubstr(c.dir + "/chain40000.osim:"));
  EXPECT_THAT(msg, HasSubstr("BezierSpline"));
  expectNoOutputs(c);
}

// OpenSim's InverseKinematicsTool looks only at applied tasks: an unapplied task may name
// anything; an applied marker task naming a marker the model lacks is skipped (kneesim says so);
// an applied coordinate task must name a model coordinate.
TEST(IkTool, TaskRulesAreOpenSims) {
  const ChainCase c = makeChainCase("task");
  const std::string original = slurp(c.setup);
  // Not applied: no error, the other five markers tracked as before.
  spit(c.setup, replaced(replaced(original, "<IKMarkerTask name=\"mE\">\n\t\t\t\t\t<apply>true</apply>",
                                  "<IKMarkerTask name=\"mZ\">\n\t\t\t\t\t<apply>false</apply>"),
                         "<IKCoordinateTask name=\"q_pin\">", "<IKCoordinateTask name=\"q_nowhere\">"));
  IkReport r = runSetup(c.setup);
  EXPECT_EQ(r.markers.size(), 5u);
  for (const auto& w : r.warnings) EXPECT_EQ(w.find("mZ"), std::string::npos) << w;
  // Applied, the model lacks the marker: a warning, the others tracked.
  spit(c.setup, replaced(original, "<IKMarkerTask name=\"mE\">", "<IKMarkerTask name=\"mZ\">"));
  r = runSetup(c.setup);
  EXPECT_EQ(r.markers.size(), 5u);
  bool warned = false;
  for (const auto& w : r.warnings)
    warned = warned || w == "1 applied marker task names a marker the model (" + c.dir +
                                "/chain40000.osim) does not have, not tracked: mZ";
  EXPECT_TRUE(warned);
  // Applied coordinate task naming no coordinate: an error at the task, and no output.
  fs::remove_all(c.dir + "/results");
  spit(c.setup, replaced(original, "<IKCoordinateTask name=\"q_pin\">\n\t\t\t\t\t<apply>false</apply>",
                         "<IKCoordinateTask name=\"q_nowhere\">\n\t\t\t\t\t<apply>true</apply>"));
  EXPECT_EQ(errorOf(c.setup), c.setup + ":36: OpenSimDocument/InverseKinematicsTool[chain]/IKTaskSet[chain_tasks]/objects/"
                                        "IKCoordinateTask[q_nowhere]: task names coordinate 'q_nowhere' which the model (" +
                                  c.dir + "/chain40000.osim) does not have");
  expectNoOutputs(c);
  // No applied marker task: every model marker found in the data, at weight 1 (OpenSim's default).
  std::string none = original;
  for (const char* mk : {"mA", "mA2", "mB", "mC", "mD", "mE"})
    none = replaced(none, std::string("<IKMarkerTask name=\"") + mk + "\">\n\t\t\t\t\t<apply>true</apply>",
                    std::string("<IKMarkerTask name=\"") + mk + "\">\n\t\t\t\t\t<apply>false</apply>");
  spit(c.setup, none);
  r = runSetup(c.setup);
  EXPECT_EQ(r.markers.size(), 6u);
  EXPECT_LT(r.max_error, 1e-6);
}

// OpenSim clips the time range to the data and moves each end to the nearest frame: 0.004 to
// 0.186 s over frames every 0.01 s from 0 is all 20 frames, 0 to 0.19 s.
TEST(IkTool, TimeRangeEndsMoveToTheNearestFrames) {
  const ChainCase c = makeChainCase("nearest");
  spit(c.setup, replaced(slurp(c.setup), "<time_range>0 0.19", "<time_range>0.004 0.186"));
  IkReport r = runSetup(c.setup);
  ASSERT_EQ(r.frames_solved, 20);
  EXPECT_NEAR(r.time.front(), 0.0, 1e-12);
  EXPECT_NEAR(r.time.back(), 0.19, 1e-12);
  spit(c.setup, replaced(slurp(c.setup), "<time_range>0.004 0.186", "<time_range>-1 0.126"));
  r = runSetup(c.setup);
  ASSERT_EQ(r.frames_solved, 14);  // 0 to 0.13 s
  EXPECT_NEAR(r.time.back(), 0.13, 1e-12);
}

// Components kneesim reads past that pose the model in OpenSim (here a ligament) are named in
// one warning line of the IK run.
TEST(IkTool, WarnsWhenIgnoredComponentsPoseTheModel) {
  const ChainCase c = makeChainCase("ligament");
  const std::string model = c.dir + "/chain40000.osim";
  spit(model, replaced(slurp(model), "<ForceSet name=\"forceset\">\n\t\t\t<objects>",
                       "<ForceSet name=\"forceset\">\n\t\t\t<objects><Blankevoort1991Ligament name=\"mcl\"/>"));
  const IkReport r = runSetup(c.setup);
  int lines = 0;
  for (const auto& w : r.warnings)
    if (w.find("not simulated; in OpenSim they help decide where the bodies go") != std::string::npos) {
      ++lines;
      EXPECT_EQ(w, model + ": 1 ligament (Blankevoort1991Ligament) not simulated; in OpenSim they help decide where the "
                           "bodies go, here the kinematics ignore them");
    }
  EXPECT_EQ(lines, 1);
}

TEST(IkTool, TaskMarkerMissingFromTheDataIsAWarning) {
  ChainCase c = makeChainCase("absent");
  io::MarkerTable t = c.markers;
  t.labels[5] = "somethingElse";
  io::writeTrc(c.dir + "/chain.trc", t, "mm");
  const IkReport r = runSetup(c.setup);
  bool warned = false;
  for (const auto& w : r.warnings) warned = warned || w == "1 task marker is not in " + c.dir + "/chain.trc and not tracked: mE";
  EXPECT_TRUE(warned);
  EXPECT_EQ(r.markers.size(), 5u);
}

TEST(IkTool, FrameWithEveryMarkerMissingIsSkippedWithAWarning) {
  ChainCase c = makeChainCase("gap");
  io::MarkerTable t = c.markers;
  for (int i = 0; i < t.getNumMarkers(); ++i) t.updPosition(6, i) = Vec3::Constant(std::nan(""));
  t.updPosition(9, 2) = Vec3::Constant(std::nan(""));  // one gap elsewhere: that frame is solved
  io::writeTrc(c.dir + "/chain.trc", t, "mm");
  const IkReport r = runSetup(c.setup);
  EXPECT_EQ(r.frames_total, 20);
  EXPECT_EQ(r.frames_solved, 19);
  bool warned = false;
  for (const auto& w : r.warnings)
    warned = warned || w == "frame 7 (t = 0.06 s) of " + c.dir + "/chain.trc: every tracked marker is missing; frame skipped";
  EXPECT_TRUE(warned);
  const io::Storage mot = io::readStorage(c.dir + "/results/chain_ik.mot");
  ASSERT_EQ(mot.getNumRows(), 19);
  EXPECT_NEAR(mot.data(5, 0), 0.05, 1e-12);
  EXPECT_NEAR(mot.data(6, 0), 0.07, 1e-12);
  EXPECT_EQ(r.frames[8].markers_used, 5);  // frame 9 (t = 0.09) without mB
  const io::Storage table = io::readStorage(c.dir + "/results/chain_ik_marker_error_table.sto");
  EXPECT_TRUE(std::isnan(table.data(8, 3)));
  // Every frame without markers: an error, and nothing written.
  for (int f = 0; f < t.getNumFrames(); ++f)
    for (int i = 0; i < t.getNumMarkers(); ++i) t.updPosition(f, i) = Vec3::Constant(std::nan(""));
  io::writeTrc(c.dir + "/chain.trc", t, "mm");
  fs::remove_all(c.dir + "/results");
  EXPECT_THAT(errorOf(c.setup), HasSubstr(c.dir + "/chain.trc: expected at least one frame with a tracked marker"));
  expectNoOutputs(c);
}

TEST(IkTool, TimeRangeOutsideTheDataIsAnError) {
  const ChainCase c = makeChainCase("range");
  spit(c.setup, replaced(slurp(c.setup), "<time_range>0 0.19", "<time_range>5 6"));
  EXPECT_EQ(errorOf(c.setup), c.setup + ":46: OpenSimDocument/InverseKinematicsTool[chain]/time_range: expected a time "
                                        "range overlapping the marker data (0 to 0.19 s in " +
                                  c.dir + "/chain.trc), got 5 to 6 s");
  spit(c.setup, replaced(slurp(c.setup), "<time_range>5 6", "<time_range>0.1 0.05"));
  EXPECT_THAT(errorOf(c.setup), HasSubstr("time_range: expected start <= end, got 0.1 0.05"));
  expectNoOutputs(c);
}

TEST(IkTool, UnknownUnitsAndTruncatedTrcNameTheMarkerFileLine) {
  const ChainCase c = makeChainCase("trc");
  const std::string trc = slurp(c.dir + "/chain.trc");
  // Line 3 holds the values of the header keys; "mm" is the fifth.
  spit(c.dir + "/chain.trc", replaced(trc, "\tmm\t", "\tfurlongs\t"));
  std::string msg = errorOf(c.setup);
  EXPECT_THAT(msg, HasSubstr(c.dir + "/chain.trc:3:"));
  EXPECT_THAT(msg, HasSubstr("furlongs"));
  expectNoOutputs(c);
  // Cut after the 12th data row (NumFrames says 20).
  size_t at = 0;
  for (int line = 0; line < 6 + 12; ++line) at = trc.find('\n', at) + 1;
  spit(c.dir + "/chain.trc", trc.substr(0, at));
  msg = errorOf(c.setup);
  EXPECT_THAT(msg, HasSubstr(c.dir + "/chain.trc:"));
  EXPECT_THAT(msg, HasSubstr("truncated"));
  expectNoOutputs(c);
}

TEST(IkTool, RunsFromC3dAndRejectsATruncatedOne) {
  ChainCase c = makeChainCase("c3d");
  io::C3dFile file;
  file.markers = c.markers;
  io::writeC3d(c.dir + "/chain.c3d", file);
  spit(c.setup, replaced(slurp(c.setup), "<marker_file>chain.trc", "<marker_file>chain.c3d"));
  const IkReport r = runSetup(c.setup);
  EXPECT_EQ(r.frames_solved, 20);
  EXPECT_LT(r.max_error, 1e-5);  // C3D floats keep ~1e-7 relative
  fs::remove_all(c.dir + "/results");
  const std::string bytes = slurp(c.dir + "/chain.c3d");
  spit(c.dir + "/chain.c3d", bytes.substr(0, bytes.size() - 1000));  // into the frames
  const std::string msg = errorOf(c.setup);
  EXPECT_THAT(msg, HasSubstr(c.dir + "/chain.c3d:"));
  EXPECT_THAT(msg, HasSubstr("truncated"));
  expectNoOutputs(c);
}

TEST(IkTool, AFailedRunLeavesEarlierOutputsUntouchedAndWritesNoneOfItsOwn) {
  const ChainCase c = makeChainCase("atomic");
  runSetup(c.setup);
  const std::string before = slurp(c.dir + "/results/chain_ik.mot");
  // Second run: the reports cannot be created (their folder is a file), so the motion, staged
  // first, must not replace the earlier one either.
  spit(c.setup, replaced(replaced(slurp(c.setup), "<results_directory>results", "<results_directory>blocked/deeper"),
                         "<time_range>0 0.19", "<time_range>0 0.1"));
  spit(c.dir + "/blocked", "a file where a folder is needed");
  EXPECT_THAT(errorOf(c.setup), HasSubstr(c.dir + "/blocked/deeper/chain_ik_marker_errors.sto: cannot create output file"));
  EXPECT_EQ(slurp(c.dir + "/results/chain_ik.mot"), before);
  EXPECT_EQ(listFiles(c.dir + "/results").size(), 5u);
  for (const std::string& f : listFiles(c.dir)) EXPECT_EQ(f.find(".tmp"), std::string::npos) << f;
}

// --------------------------------------------------------------------------------------------
// Real data.

// OpenSim's own regression case (Applications/IK/tests in opensim-core): gait2354 (format
// 20303, SimmSpline knees), its synthetic markers, its stored answer. OpenSim accepts each of the
// 24 columns within 0.2 (degrees, or metres for translations) RMS.
TEST(IkTool, Gait2354MatchesOpenSimsStoredAnswer) {
  KNEESIM_REQUIRE_DATA("opensim-ik-tests/subject01_Setup_InverseKinematics.xml");
  const std::string dir = test::scratchDir("iktool_gait2354");
  for (const auto& e : fs::directory_iterator(test::dataPath("opensim-ik-tests")))
    fs::copy_file(e.path(), dir + "/" + e.path().filename().string());
  const IkReport r = runSetup(dir + "/subject01_Setup_InverseKinematics.xml");
  EXPECT_EQ(r.frames_solved, 73);
  // report_errors false, report_marker_locations true in OpenSim's setup.
  EXPECT_EQ(r.outputs, (std::vector<std::string>{dir + "/subject01_walk1_ik_test.mot",
                                                 dir + "/subject01_ik_model_marker_locations.sto"}));
  const io::Storage ours = io::readStorage(dir + "/subject01_walk1_ik_test.mot");
  const io::Storage standard = io::readStorage(dir + "/std_subject01_walk1_ik.mot");
  const io::MotionComparison cmp = io::compareMotions(ours, standard, "std_subject01_walk1_ik.mot");
  EXPECT_EQ(cmp.rows_matched, 73);
  EXPECT_EQ(cmp.columns.size(), 23u);  // + time = OpenSim's 24 columns
  EXPECT_TRUE(cmp.only_in_first.empty());
  EXPECT_TRUE(cmp.only_in_second.empty());
  for (const auto& col : cmp.columns) {
    EXPECT_LT(col.rms, 0.2) << col.label;    // OpenSim's tolerance
    EXPECT_LT(col.rms, 0.02) << col.label;   // what kneesim reaches (0.008 measured)
    EXPECT_LT(col.max, 0.05) << col.label;
  }
  // Markers at least as close as OpenSim's answer puts them (its mean RMS is 0.030 mm).
  const auto model = model::readOsim(dir + "/subject01_simbody.osim");
  sim::System sys(model);
  auto ws = sys.createWorkspace();
  const io::MarkerTable markers = io::readMarkerFile(dir + "/subject01_synthetic_marker_data.trc");
  double opensim_rms = 0;
  for (int row = 0; row < standard.getNumRows(); ++row) {
    sys.realizePosition(*ws, coordinatesOfRow(*model, standard, row));
    int frame = 0;
    while (std::abs(markers.time[frame] - standard.data(row, 0)) > 1e-6) ++frame;
    double sum2 = 0;
    for (const auto& s : r.markers) {
      const auto& mk = model->markers[model->findMarker(s.name)];
      sum2 += (sys.findStationLocation(*ws, mk.body, mk.p_BM) - markers.getPosition(frame, markers.findMarker(s.name))).squaredNorm();
    }
    opensim_rms += std::sqrt(sum2 / r.markers.size()) / standard.getNumRows();
  }
  EXPECT_GT(opensim_rms, 0.02e-3);
  EXPECT_LT(r.mean_rms, opensim_rms);
  EXPECT_LT(r.mean_rms, 0.02e-3);
}

// OpenSim's constraintTest: 25 CustomJoints with NaturalCubicSpline and PiecewiseLinearFunction
// axes, 8 coordinate couplers, constraint_weight 10. OpenSim only requires that it runs; kneesim
// also holds every coupler to 1e-6 on the written motion (checked with Simbody's own constraint
// errors) and explains the large marker errors by the data.
TEST(IkTool, ConstraintTestHoldsEveryCoupler) {
  KNEESIM_REQUIRE_DATA("opensim-ik-tests/constraintTest_setup_ik.xml");
  const std::string dir = test::scratchDir("iktool_constraint");
  for (const char* f : {"constraintTest_setup_ik.xml", "constraintTest_ikOnly.osim", "constraintTest.trc"})
    fs::copy_file(test::dataPath(std::string("opensim-ik-tests/") + f), dir + "/" + f);
  const IkReport r = runSetup(dir + "/constraintTest_setup_ik.xml");
  EXPECT_EQ(r.frames_solved, 101);
  const auto model = model::readOsim(dir + "/constraintTest_ikOnly.osim");
  ASSERT_EQ(model->couplers.size(), 8u);
  sim::System sys(model);
  auto ws = sys.createWorkspace();
  const io::Storage mot = io::readStorage(dir + "/constraintTest_ik_new.mot");
  ASSERT_EQ(mot.getNumRows(), 101);
  double worst = 0;
  for (int row = 0; row < mot.getNumRows(); ++row) {
    sys.realizePosition(*ws, coordinatesOfRow(*model, mot, row));
    worst = std::max(worst, sys.calcCouplerErrors(*ws).cwiseAbs().maxCoeff());
  }
  EXPECT_LT(worst, 1e-6);
  // The model's markers were never placed on this subject: R.SH2, R.SH3 and R.SH4 sit on one point
  // of the tibia, L.TH1 and L.TH2 on one point of the femur, while the data hold distinct
  // markers; and L.Scapula sits 0.53 m below the clavicle markers on the torso while the data
  // put it at their height. So the large errors are the data's: for markers sharing a model
  // point, the two errors add up to at least their distance in the data, in every frame.
  auto p = [&](const std::string& n) { return model->markers[model->findMarker(n)].p_BM; };
  EXPECT_EQ(p("R.SH2"), p("R.SH3"));
  EXPECT_EQ(p("L.TH1"), p("L.TH2"));
  const io::MarkerTable data = io::readMarkerFile(dir + "/constraintTest.trc");
  const io::Storage table = io::readStorage(dir + "/ik_marker_error_table.sto");
  for (const auto& [a, b] : std::vector<std::pair<std::string, std::string>>{{"R.SH2", "R.SH3"}, {"L.TH1", "L.TH2"}})
    for (int row = 0; row < table.getNumRows(); ++row) {
      const double d = (data.getPosition(row, data.findMarker(a)) - data.getPosition(row, data.findMarker(b))).norm();
      EXPECT_GT(d, 0.04);
      EXPECT_GE(table.data(row, table.findColumn(a)) + table.data(row, table.findColumn(b)), d - 1e-9);
    }
  const auto& scapula = *std::find_if(r.markers.begin(), r.markers.end(), [](const auto& s) { return s.name == "L.Scapula"; });
  EXPECT_GT(scapula.mean, 0.5);
  EXPECT_NEAR(p("L.Clavicle").y() - p("L.Scapula").y(), 0.53, 1e-12);
  EXPECT_LT(r.mean_rms, 0.120);  // 116.9 mm measured; a regression would show here
}

// IK straight from a Vicon C3D of subject JW with the University of Florida model: the model's
// markers are named with dots (R.Thigh.Superior), the C3D's without (RThighSuperior), the lab is
// Z-up and the model Y-up.
TEST(IkTool, JwGaitFromC3dWithTheUfModel) {
  KNEESIM_REQUIRE_DATA("kgc4-jw/markers/jw_ngait_og3.c3d");
  const std::string dir = test::scratchDir("iktool_jw");
  spit(dir + "/setup.xml",
       "<OpenSimDocument Version=\"30000\"><InverseKinematicsTool name=\"og3\">\n"
       "<model_file>" + test::dataPath("kgc4-jw/model/jw_all_body_scaled.osim") + "</model_file>\n"
       "<marker_file>" + test::dataPath("kgc4-jw/markers/jw_ngait_og3.c3d") + "</marker_file>\n"
       "<marker_rotation>-90 0 0</marker_rotation>\n"
       "<output_motion_file>og3_ik.mot</output_motion_file>\n"
       "</InverseKinematicsTool></OpenSimDocument>\n");
  const IkReport r = runSetup(dir + "/setup.xml");
  EXPECT_EQ(r.frames_solved, 291);
  // No task set: every model marker found in the data. 41 of the model's 54 are in the C3D; the
  // 36 named with dots are found by ignoring the separators.
  EXPECT_EQ(r.markers.size(), 41u);
  EXPECT_EQ(r.loose_name_matches, 36);
  std::map<std::string, std::string> label;
  for (const auto& s : r.markers) label[s.name] = s.data_label;
  EXPECT_EQ(label["R.Thigh.Superior"], "RThighSuperior");
  EXPECT_EQ(label["R.Midfoot.Lateral"], "RMidfootLateral");
  EXPECT_EQ(label["Sternum"], "Sternum");
  EXPECT_EQ(label.count("R.Knee.Lateral"), 0u);  // from a static trial, not in gait C3Ds
  // The right (instrumented) leg fits within a centimetre or two; the whole body within 3 cm RMS
  // (27.8 mm measured; the left arm markers are 4-11 cm off on this rebuilt model).
  for (const auto& s : r.markers)
    if (s.name.rfind("R.Shank", 0) == 0 || s.name.rfind("R.Heel", 0) == 0 || s.name.rfind("R.Toe", 0) == 0) {
      EXPECT_LT(s.rms, 0.012) << s.name;
    }
  EXPECT_LT(r.mean_rms, 0.030);
  // Plausible gait: pelvis about 1 m up (Y-up after the rotation), knee flexing through ~60 deg.
  const io::Storage mot = io::readStorage(dir + "/og3_ik.mot");
  const Eigen::VectorXd ty = mot.getColumn("pelvis_ty"), knee = mot.getColumn("knee_flexion");
  EXPECT_GT(ty.minCoeff(), 0.9);
  EXPECT_LT(ty.maxCoeff(), 1.05);
  EXPECT_GT(knee.maxCoeff() - knee.minCoeff(), 55.0);
  EXPECT_LT(knee.maxCoeff() - knee.minCoeff(), 80.0);
  // Both couplers of the model (patellofemoral on knee flexion) hold.
  const auto model = model::readOsim(test::dataPath("kgc4-jw/model/jw_all_body_scaled.osim"));
  sim::System sys(model);
  auto ws = sys.createWorkspace();
  for (int row = 0; row < mot.getNumRows(); row += 10) {
    sys.realizePosition(*ws, coordinatesOfRow(*model, mot, row));
    EXPECT_LT(sys.calcCouplerErrors(*ws).cwiseAbs().maxCoeff(), 1e-6);
  }
}

}  // namespace
}  // namespace kneesim::ik
