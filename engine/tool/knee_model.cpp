// Building the knee model (tool/knee_model.hpp, steps 1-6 there): a Builder whose member functions
// are the steps, and writing the model and its path table (runKneeModelTool).

#include "tool/knee_model.hpp"

#include <algorithm>
#include <array>
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <map>
#include <memory>
#include <optional>
#include <set>
#include <sstream>

#include "contact/condyle.hpp"
#include "contact/mesh_distance.hpp"
#include "contact/seating.hpp"
#include "core/atomic_file.hpp"
#include "core/error.hpp"
#include "core/strings.hpp"
#include "core/xml.hpp"
#include "io/stl.hpp"
#include "model/osim_reader.hpp"
#include "model/osim_writer.hpp"
#include "sim/system.hpp"
#include "tool/knee_model_detail.hpp"

namespace kneesim::tool {

namespace fs = std::filesystem;
using detail::kDeg;
using detail::kKneeModelBodyNames;
using Eigen::Isometry3d;
using Eigen::Matrix3d;
using Eigen::Vector3d;

namespace {

// Local linear regression with tricube weights of half-width h, evaluated at each t.
std::vector<double> smoothLocalLinear(const std::vector<double>& t, const std::vector<double>& y, double h) {
  std::vector<double> out(t.size());
  for (size_t i = 0; i < t.size(); ++i) {
    double sw = 0, st = 0, sy = 0, stt = 0, sty = 0;
    for (size_t j = 0; j < t.size(); ++j) {
      const double u = std::abs(t[j] - t[i]) / h;
      if (u >= 1) continue;
      const double w = std::pow(1 - u * u * u, 3);
      const double dt = t[j] - t[i];
      sw += w;
      st += w * dt;
      sy += w * y[j];
      stt += w * dt * dt;
      sty += w * dt * y[j];
    }
    const double det = sw * stt - st * st;
    out[i] = std::abs(det) > 1e-300 ? (stt * sy - st * sty) / det : sy / sw;
  }
  return out;
}

// R = Rz(a) Rx(b) Ry(c): returns (a, b, c).
Vector3d decomposeZXY(const Matrix3d& R) {
  const double b = std::atan2(R(2, 1), std::hypot(R(2, 0), R(2, 2)));
  return Vector3d(std::atan2(-R(0, 1), R(1, 1)), b, std::atan2(-R(2, 0), R(2, 2)));
}

Matrix3d rotZ(double a) { return Eigen::AngleAxisd(a, Vector3d::UnitZ()).toRotationMatrix(); }

std::string fmt(const char* f, double a) {
  char buf[256];
  std::snprintf(buf, sizeof buf, f, a);
  return buf;
}

// Signed distance of the patellar button's dome points to the femoral component.
class ButtonContact {
 public:
  ButtonContact(const io::TriangleMesh& femur, const io::TriangleMesh& button)
      : femur_(femur), button_file_(button.source_file) {
    // The dome: everything in front of the flat back (x = 0 in the button's frame) by more than
    // 1 mm; the pegs behind it never meet the femur.
    for (const Vector3d& v : button.vertices)
      if (v.x() > 1e-3) dome_.push_back(v);
    if (dome_.empty())
      throw InputError({button.source_file, 0, ""}, "expected a patellar button dome (vertices with x > 1 mm), got none");
  }
  /// Smallest signed distance of the dome to the femoral component with the button at X_FP.
  double calcGap(const Isometry3d& X_FP) const {
    double d = 1.0;
    contact::MeshDistanceQuery q;
    // Search a fixed 20 mm: pruning by the smallest distance so far would miss points that are
    // deeper inside the component than that distance.
    for (const Vector3d& p : dome_)
      if (femur_.calcSignedDistance(X_FP * p, 0.02, q)) d = std::min(d, q.distance);
    return d;
  }
  /// The offset s along the unit direction @p e_F (in F) at which the button at
  /// X_FP = [R | p + s e] first touches the femoral component when it comes in from s_far
  /// (outside) toward smaller s. The component is a shell: coming from outside matters.
  double calcTouchingOffset(const Matrix3d& R, const Vector3d& p, const Vector3d& e_F, double s_far) const {
    auto gap = [&](double s) {
      Isometry3d X = Isometry3d::Identity();
      X.linear() = R;
      X.translation() = p + s * e_F;
      return calcGap(X);
    };
    double hi = s_far, ghi = gap(hi), lo = hi, glo = ghi;
    if (!(ghi > 0))
      throw InputError({button_file_, 0, ""}, "expected the patellar button clear of the femoral component " +
                                                  std::to_string(s_far * 1e3) + " mm out, got a contact there");
    const double step = 1e-3;  // thinner than the component's flange
    for (int k = 0; k < 200 && glo > 0; ++k) {
      hi = lo;
      ghi = glo;
      lo -= step;
      glo = gap(lo);
    }
    if (!(glo <= 0 && ghi > 0))
      throw InputError({button_file_, 0, ""},
                       "expected the patellar button to meet the femoral component within 200 mm, got no contact "
                       "(are the button and the femoral component in the implant frames?)");
    // Illinois false position.
    int side = 0;
    for (int it = 0; it < 100 && hi - lo > 1e-10; ++it) {
      const double s = hi - ghi * (hi - lo) / (ghi - glo);
      const double g = gap(s);
      if (std::abs(g) < 1e-9) return s;
      if (g > 0) {
        hi = s;
        ghi = g;
        if (side == 1) glo *= 0.5;
        side = 1;
      } else {
        lo = s;
        glo = g;
        if (side == -1) ghi *= 0.5;
        side = -1;
      }
    }
    return 0.5 * (lo + hi);
  }

 private:
  contact::MeshDistance femur_;
  std::string button_file_;
  std::vector<Vector3d> dome_;
};

struct SourceParts {
  int body[9];
  int joint[9];
};

const char* const kBodyNames[9] = {"pelvis", "femur", "femoral_component", "tibial_tray", "tibia",
                                   "patella", "talus", "calcaneus", "toes"};
enum { kPelvis, kFemur, kFemoral, kTray, kTibia, kPatella, kTalus, kCalcaneus, kToes };

// The six transform axes of the knee's and the patellofemoral joint's CustomJoint, each driven
// one to one by its coordinate c[a]: flexion (z), adduction (-x), rotation (y), then the
// translations along -x, y and -z.
void setKneeAxes(model::Joint& j, const int c[6]) {
  j.coordinates.assign(c, c + 6);
  const Vector3d axes[6] = {Vector3d(0, 0, 1),  Vector3d(-1, 0, 0), Vector3d(0, 1, 0),
                            Vector3d(-1, 0, 0), Vector3d(0, 1, 0),  Vector3d(0, 0, -1)};
  for (int a = 0; a < 6; ++a) {
    j.spatial[a].axis = axes[a];
    j.spatial[a].coordinates = {c[a]};
    j.spatial[a].function = model::makeLinear(1.0, 0.0);
  }
}

}  // namespace

namespace {

// One build of the knee model: the state the steps of the header's list share, and one member
// function a step. run() is the order of the steps.
class Builder {
 public:
  explicit Builder(const KneeModelSetup& s) : s(s), at_setup{s.setup_file, 0, ""} {}

  KneeModelResult run() {
    src = model::readOsim(s.source_model_file);
    findSourceParts();
    const io::StlOptions implant_opt{1.0, true, 0.01, 0.5};
    femur_mesh = io::readStl(s.femoral_component_file, implant_opt);
    insert_mesh = io::readStl(s.tibial_insert_file, implant_opt);
    button_mesh = io::readStl(s.patellar_button_file, implant_opt);
    checkFrames();
    seatPath();
    calcKneeFrames();
    placePatella();
    assembleModel();
    checkThroughModel();
    writeReportLines();
    return {m, rep};
  }

 private:
  void findSourceParts();
  void expectParent(int child, int parent) const;
  void checkFrames();
  void seatPath();
  void calcKneeFrames();
  void placePatella();
  void assembleModel();
  void addBodies();
  void addMesh(int part, const std::string& file, const Isometry3d& X_BG);
  int copyCoordinate(int c);
  int copyJoint(int part, int parent_part);
  int addCoordinate(const std::string& name, model::MotionType mt, double lo, double hi, bool clamped, bool locked,
                    double def);
  // A CustomJoint from part parent_part to part child_part with frames X_PF and X_BM (no axes yet).
  static model::Joint makeCustomJoint(const char* name, int parent_part, int child_part, const Isometry3d& X_PF,
                                      const Isometry3d& X_BM);
  void addKneeJoint();
  void addPatfemJoint();
  void setRanges();
  void addMarkers();
  void checkThroughModel();
  void writeReportLines();

  // The pose in ground of a part of the source model at its default pose.
  Isometry3d X_G(int part) const { return src_sys->getBodyPose(*src_ws, parts.body[part]); }
  static int nb(int part) { return part + 1; }  // new body index of a part

  const KneeModelSetup& s;
  const SourceLocation at_setup;
  KneeModelReport rep;
  model::ModelPtr src;
  SourceParts parts;
  io::TriangleMesh femur_mesh, insert_mesh, button_mesh;
  // 1. Frame checks.
  std::optional<sim::System> src_sys;
  std::unique_ptr<sim::Workspace> src_ws;
  Isometry3d X_TF_src, X_F_patsrc;
  contact::CondyleFits fits;
  std::optional<contact::Seater> seater;
  // 2. The seated path.
  int nk = 0, k0 = 0, kn = 0;  // number of knots, the zero-flexion knot, the neutral knot
  std::vector<Isometry3d> X_IF;
  // 3. The knee joint's frames and coordinates at the knots.
  Isometry3d X_F_Fj, X_T_Tj;
  std::vector<std::array<double, 6>> knee_q;
  std::vector<double> flex_x;
  double flex_default = 0;
  // 4. The patella.
  std::optional<ButtonContact> button;
  Vector3d p0;  // button frame origin in F at zero flexion
  std::vector<double> pf_tx, pf_ty, pf_knots;
  Isometry3d X_F_P0, X_P_patsrc;
  // 5. The model.
  std::shared_ptr<model::Model> m;
  std::map<int, int> coord_map;  // source coordinate -> new
};

void Builder::findSourceParts() {
  for (int i = 0; i < 9; ++i) {
    parts.body[i] = src->findBody(kBodyNames[i]);
    if (parts.body[i] < 0)
      throw InputError({s.setup_file, 0, "source_model_file"},
                       std::string("expected a body '") + kBodyNames[i] + "' in " + s.source_model_file + ", got none");
    parts.joint[i] = src->findParentJoint(parts.body[i]);
  }
  expectParent(kFemur, kPelvis);
  expectParent(kFemoral, kFemur);
  expectParent(kTray, kFemoral);
  expectParent(kTibia, kTray);
  expectParent(kPatella, kFemoral);
  expectParent(kTalus, kTibia);
  expectParent(kCalcaneus, kTalus);
  expectParent(kToes, kCalcaneus);
  if (src->joints[parts.joint[kFemoral]].type != model::JointType::Weld ||
      src->joints[parts.joint[kTibia]].type != model::JointType::Weld)
    throw InputError({s.setup_file, 0, "source_model_file"},
                     "expected the femoral component and the tibia to be welded to the femur and the tray");
}

void Builder::expectParent(int child, int parent) const {
  const model::Joint& j = src->joints[parts.joint[child]];
  if (j.parent_body != parts.body[parent])
    throw InputError({s.setup_file, 0, "source_model_file"},
                     "expected joint '" + j.name + "' to connect '" + kBodyNames[parent] + "' to '" + kBodyNames[child] +
                         "', got parent '" + src->bodies[j.parent_body].name + "'");
}

void Builder::checkFrames() {
  src_sys.emplace(src);
  src_ws = src_sys->createWorkspace();
  Eigen::VectorXd q_src = src_sys->getDefaultCoordinates();
  for (const auto& cc : src->couplers) {  // a consistent default (the patella follows the knee)
    double x[6];
    for (size_t k = 0; k < cc.independents.size(); ++k) x[k] = q_src[cc.independents[k]];
    q_src[cc.dependent] = cc.scale_factor * cc.function->calcValue(x);
  }
  src_sys->realizePosition(*src_ws, q_src);
  X_TF_src = X_G(kTray).inverse() * X_G(kFemoral);
  X_F_patsrc = X_G(kFemoral).inverse() * X_G(kPatella);

  fits = contact::fitCondyles(femur_mesh, contact::ArticularSelection{});
  rep.hinge_radius = fits.both.cylinder.radius;
  seater.emplace(contact::makeSeatingSetup(femur_mesh, insert_mesh, fits.both.cylinder));
  {
    double gap[2];
    seater->calcGaps(X_TF_src, 0.05, gap, nullptr);
    rep.source_gap_medial = gap[0];
    rep.source_gap_lateral = gap[1];
  }
  // Femoral component's superior axis against the femur's mechanical axis (knee to hip centre).
  {
    const Isometry3d X_femur_F = X_G(kFemur).inverse() * X_G(kFemoral);
    const Vector3d hip_F = X_femur_F.inverse() * Vector3d::Zero();  // femur origin = hip centre
    const Vector3d mech = hip_F.normalized();                        // in F: x posterior, z medial
    rep.femur_axis_flexion = std::atan2(mech.x(), mech.y());   // the component's top tilted anteriorly: > 0
    rep.femur_axis_coronal = std::atan2(-mech.z(), mech.y());  // its top tilted medially of the axis: > 0
  }
  // CT bones are drawn in the tray frame: the talus against the ankle centre, the fibula's head.
  {
    const model::Joint& ankle = src->joints[parts.joint[kTalus]];
    const Isometry3d X_T_tibia = X_G(kTray).inverse() * X_G(kTibia);
    const Vector3d ankle_T = X_T_tibia * ankle.X_PF.translation();
    if (!s.talus_file.empty()) {
      const io::TriangleMesh talus = io::readStl(s.talus_file);
      Vector3d c = Vector3d::Zero();
      for (const Vector3d& v : talus.vertices) c += v;
      c /= double(talus.vertices.size());
      rep.talus_minus_ankle = c - ankle_T;
    }
  }
  if (!s.fibula_file.empty()) {
    const io::TriangleMesh fibula_mesh = io::readStl(s.fibula_file, {1.0, false, 0.01, 0.6});
    rep.fibula_top = fibula_mesh.calcBounds().second.y();
  }
  if (!s.patella_bone_file.empty()) {
    const io::TriangleMesh patella_mesh = io::readStl(s.patella_bone_file, {1.0, false, 0.01, 0.2});
    rep.patella_cut_offset = patella_mesh.calcBounds().second.x();
  }
}

void Builder::seatPath() {
  const std::vector<double>& knots = s.flexion_knots;
  nk = int(knots.size());
  for (int k = 0; k < nk; ++k) {
    if (std::abs(knots[k]) < 1e-9) k0 = k;
    if (std::abs(knots[k] - s.neutral_flexion) < 1e-9) kn = k;
  }
  std::vector<contact::SeatingResult> lowest(nk);
  lowest[kn] = seater->calcSeating(knots[kn]);
  for (int k = kn + 1; k < nk; ++k) lowest[k] = seater->calcSeating(knots[k], &lowest[k - 1].q);
  for (int k = kn - 1; k >= 0; --k) lowest[k] = seater->calcSeating(knots[k], &lowest[k + 1].q);
  for (int k = 0; k < nk; ++k)
    if (!(std::max(std::abs(lowest[k].gap_medial), std::abs(lowest[k].gap_lateral)) <= 1e-6))
      throw InputError(at_setup, "seating failed at " + fmt("%.1f", knots[k] / kDeg) + " deg flexion (gaps " +
                                     fmt("%.3g", lowest[k].gap_medial) + ", " + fmt("%.3g", lowest[k].gap_lateral) + " m)");
  rep.neutral_gap_medial = lowest[kn].gap_medial;
  rep.neutral_gap_lateral = lowest[kn].gap_lateral;
  rep.neutral_hinge_I = lowest[kn].q.p_IH;

  std::vector<double> ap(nk), ml(nk);
  for (int k = 0; k < nk; ++k) {
    ap[k] = lowest[k].q.p_IH.x();
    ml[k] = lowest[k].q.p_IH.z();
  }
  std::vector<double> ap_s = smoothLocalLinear(knots, ap, s.smoothing_window);
  std::vector<double> ml_s = smoothLocalLinear(knots, ml, s.smoothing_window);
  const double ap_shift = ap[kn] - ap_s[kn], ml_shift = ml[kn] - ml_s[kn];
  contact::SeatingOptions fixed_opt;
  fixed_opt.max_outer_iterations = 0;  // (h, varus) only: the position stays where it is put
  contact::Seater fixed(seater->getSetup(), fixed_opt);
  X_IF.resize(nk);
  rep.knots.resize(nk);
  for (int k = 0; k < nk; ++k) {
    contact::SeatingCoordinates start = lowest[k].q;
    start.p_IH.x() = ap_s[k] + ap_shift;
    start.p_IH.z() = ml_s[k] + ml_shift;
    const contact::SeatingResult r = fixed.calcSeating(knots[k], &start);
    if (!(std::max(std::abs(r.gap_medial), std::abs(r.gap_lateral)) <= 1e-6))
      throw InputError(at_setup, "re-seating on the smoothed path failed at " + fmt("%.1f", knots[k] / kDeg) + " deg");
    X_IF[k] = r.X_IF;
    KneePathKnot& kt = rep.knots[k];
    kt.flexion = knots[k];
    kt.gap_medial = r.gap_medial;
    kt.gap_lateral = r.gap_lateral;
    kt.height_above_lowest = r.q.p_IH.y() - lowest[k].q.p_IH.y();
    rep.max_knot_gap = std::max({rep.max_knot_gap, std::abs(r.gap_medial), std::abs(r.gap_lateral)});
    rep.max_smoothing_height = std::max(rep.max_smoothing_height, std::abs(kt.height_above_lowest));
  }
  {
    const Isometry3d D = X_TF_src.inverse() * X_IF[kn];
    rep.source_minus_seated = X_TF_src.translation() - X_IF[kn].translation();
    rep.source_seated_angle = Eigen::AngleAxisd(D.linear()).angle();
  }
}

void Builder::calcKneeFrames() {
  const Vector3d z_j = -fits.both.cylinder.axis.normalized();  // the tibia flexes about +z_j
  const Vector3d post = Vector3d::UnitX();
  const Vector3d x_j = (post - post.dot(z_j) * z_j).normalized();
  X_F_Fj = Isometry3d::Identity();
  X_F_Fj.linear() << x_j, z_j.cross(x_j), z_j;
  X_F_Fj.translation() = fits.both.cylinder.point;
  X_T_Tj = X_IF[k0] * X_F_Fj;
  knee_q.resize(nk);
  for (int k = 0; k < nk; ++k) {
    const Isometry3d X = X_F_Fj.inverse() * X_IF[k].inverse() * X_T_Tj;
    const Vector3d zxy = decomposeZXY(X.linear());
    // Axes: flexion about +z (medial), adduction about -x (anterior), rotation about +y; the
    // translations along -x (anterior), +y (superior), -z (lateral).
    knee_q[k] = {zxy[0], -zxy[1], zxy[2], -X.translation().x(), X.translation().y(), -X.translation().z()};
    for (int i = 0; i < 6; ++i) rep.knots[k].q[i] = knee_q[k][i];
  }
  for (int k = 1; k < nk; ++k)
    if (!(knee_q[k][0] > knee_q[k - 1][0]))
      throw InputError(at_setup, "expected the seated path's flexion to increase, got " +
                                     fmt("%.3f", knee_q[k][0] / kDeg) + " deg after " +
                                     fmt("%.3f", knee_q[k - 1][0] / kDeg) + " deg (knots closer than the seating's resolution?)");
  flex_x.resize(nk);
  for (int k = 0; k < nk; ++k) flex_x[k] = knee_q[k][0];
  flex_default = knee_q[kn][0];
}

void Builder::placePatella() {
  button.emplace(femur_mesh, button_mesh);
  // Neutral placement at zero flexion: button axes = F axes, dome facing posterior (toward the
  // femoral component), at the height of F's origin; medio-lateral position in the trochlear
  // groove (where the seated button sits most posterior), distance where the dome touches.
  const Vector3d anterior(-1, 0, 0);
  auto seatedX = [&](double z) {
    return -button->calcTouchingOffset(Matrix3d::Identity(), Vector3d(0, 0, z), anterior, 0.08);
  };
  double best_z = 0, best_x = -1;
  for (double z = -10e-3; z <= 10e-3 + 1e-12; z += 1e-3) {
    const double x = seatedX(z);
    if (x > best_x) {
      best_x = x;
      best_z = z;
    }
  }
  for (double h = 0.5e-3; h >= 0.02e-3; h *= 0.5) {  // refine by halving steps
    for (double z : {best_z - h, best_z + h}) {
      const double x = seatedX(z);
      if (x > best_x) {
        best_x = x;
        best_z = z;
      }
    }
  }
  p0 = Vector3d(best_x, 0, best_z);
  pf_tx.resize(nk);
  pf_ty.resize(nk);
  pf_knots.resize(nk);
  for (int k = 0; k < nk; ++k) {
    const double th = knee_q[k][0];
    const Matrix3d R = rotZ(th);
    const double delta = button->calcTouchingOffset(R, R * p0, R * anterior, 0.03);
    Isometry3d X_fixed = Isometry3d::Identity();
    X_fixed.linear() = R;
    X_fixed.translation() = R * p0;
    rep.knots[k].patella_offset = delta;
    rep.knots[k].patella_gap = button->calcGap(X_fixed);  // at the neutral radius (no offset)
    pf_knots[k] = th;
    pf_tx[k] = delta * std::cos(th);   // along the anterior axis
    pf_ty[k] = -delta * std::sin(th);  // along the superior axis
  }
  X_F_P0 = Isometry3d::Identity();
  X_F_P0.translation() = p0;
  X_P_patsrc = X_F_P0.inverse() * X_F_patsrc;
}

void Builder::assembleModel() {
  m = std::make_shared<model::Model>();
  m->name = s.name;
  m->gravity = -9.80665 * s.R_lab_model.col(1);
  addBodies();
  {  // pelvis: its parent frame turns the model's axes into the lab's
    const int j = copyJoint(kPelvis, -1);
    Isometry3d R = Isometry3d::Identity();
    R.linear() = s.R_lab_model;
    m->joints[j].X_PF = R * m->joints[j].X_PF;
  }
  copyJoint(kFemur, kPelvis);
  copyJoint(kFemoral, kFemur);
  addKneeJoint();
  copyJoint(kTibia, kTray);
  m->joints.back().name = "tibial_component_weld";
  addPatfemJoint();
  copyJoint(kTalus, kTibia);
  copyJoint(kCalcaneus, kTalus);
  copyJoint(kToes, kCalcaneus);
  setRanges();
  addMarkers();
  m->finalize();
}

void Builder::addBodies() {
  m->bodies.resize(10);
  m->bodies[0].name = "ground";
  for (int i = 0; i < 9; ++i) {
    model::Body b = src->bodies[parts.body[i]];
    b.name = kKneeModelBodyNames[i];
    b.meshes.clear();
    if (i == kPatella) {  // re-expressed in the button's frame
      b.mass_center = X_P_patsrc * b.mass_center;
      b.inertia = X_P_patsrc.linear() * b.inertia * X_P_patsrc.linear().transpose();
    }
    m->bodies[nb(i)] = b;
  }
  addMesh(kFemoral, s.femoral_component_file, Isometry3d::Identity());
  addMesh(kTray, s.tibial_tray_file, Isometry3d::Identity());
  addMesh(kTray, s.tibial_insert_file, Isometry3d::Identity());
  addMesh(kTibia, s.fibula_file, X_G(kTibia).inverse() * X_G(kTray));
  addMesh(kPatella, s.patellar_button_file, Isometry3d::Identity());
  addMesh(kPatella, s.patella_bone_file, Isometry3d::Identity());
}

void Builder::addMesh(int part, const std::string& file, const Isometry3d& X_BG) {
  if (file.empty()) return;
  const fs::path out_dir = fs::absolute(fs::path(s.output_model_file)).parent_path();
  model::MeshRef mesh;
  mesh.file = fs::absolute(file).lexically_normal().lexically_relative(out_dir).generic_string();
  mesh.resolved_path = fs::absolute(file).lexically_normal().string();
  mesh.X_BG = X_BG;
  m->bodies[nb(part)].meshes.push_back(mesh);
}

int Builder::copyCoordinate(int c) {
  coord_map[c] = int(m->coordinates.size());
  m->coordinates.push_back(src->coordinates[c]);
  m->coordinates.back().joint = -1;
  return coord_map[c];
}

int Builder::copyJoint(int part, int parent_part) {
  model::Joint j = src->joints[parts.joint[part]];
  j.parent_body = parent_part < 0 ? 0 : nb(parent_part);
  j.child_body = nb(part);
  for (int& c : j.coordinates) c = copyCoordinate(c);
  for (auto& ax : j.spatial)
    for (int& c : ax.coordinates) c = coord_map.at(c);
  m->joints.push_back(j);
  return int(m->joints.size()) - 1;
}

int Builder::addCoordinate(const std::string& name, model::MotionType mt, double lo, double hi, bool clamped,
                           bool locked, double def) {
  model::Coordinate c;
  c.name = name;
  c.motion_type = mt;
  c.range_min = lo;
  c.range_max = hi;
  c.clamped = clamped;
  c.locked = locked;
  c.default_value = def;
  m->coordinates.push_back(c);
  return int(m->coordinates.size()) - 1;
}

model::Joint Builder::makeCustomJoint(const char* name, int parent_part, int child_part, const Isometry3d& X_PF,
                                      const Isometry3d& X_BM) {
  model::Joint j;
  j.name = name;
  j.type = model::JointType::Custom;
  j.parent_body = nb(parent_part);
  j.child_body = nb(child_part);
  j.X_PF = X_PF;
  j.X_BM = X_BM;
  return j;
}

void Builder::addKneeJoint() {
  model::Joint j = makeCustomJoint("knee", kFemoral, kTray, X_F_Fj, X_T_Tj);
  const model::MotionType R = model::MotionType::Rotational, T = model::MotionType::Translational;
  const double fmin = flex_x.front(), fmax = flex_x.back();
  const int c_flex = addCoordinate("knee_flexion", R, fmin, fmax, true, false, flex_default);
  const char* names[6] = {"knee_flexion", "knee_adduction", "knee_rotation", "knee_tx", "knee_ty", "knee_tz"};
  int c[6] = {c_flex, 0, 0, 0, 0, 0};
  for (int i = 1; i < 6; ++i)
    c[i] = addCoordinate(names[i], i < 3 ? R : T, i < 3 ? -30 * kDeg : -0.05, i < 3 ? 30 * kDeg : 0.05, false, false,
                         0.0);
  setKneeAxes(j, c);
  m->joints.push_back(j);
  for (int i = 1; i < 6; ++i) {
    model::CoordinateCoupler cc;
    cc.name = std::string(names[i]) + "_path";
    cc.independents = {c_flex};
    cc.dependent = c[i];
    std::vector<double> y(nk);
    for (int k = 0; k < nk; ++k) y[k] = knee_q[k][i];
    cc.function = model::makeSimmSpline(flex_x, y);
    m->coordinates[c[i]].default_value = cc.function->calcValue(flex_default);
    m->couplers.push_back(cc);
  }
}

void Builder::addPatfemJoint() {
  // M sits on F's origin at zero flexion.
  model::Joint j = makeCustomJoint("patfem", kFemoral, kPatella, Isometry3d::Identity(), X_F_P0.inverse());
  const model::MotionType R = model::MotionType::Rotational, T = model::MotionType::Translational;
  const char* names[6] = {"patfem_flexion", "patfem_adduction", "patfem_rotation", "patfem_tx", "patfem_ty", "patfem_tz"};
  int c[6];
  c[0] = addCoordinate(names[0], R, flex_x.front(), flex_x.back(), false, false, flex_default);
  c[1] = addCoordinate(names[1], R, -30 * kDeg, 30 * kDeg, false, true, 0.0);
  c[2] = addCoordinate(names[2], R, -30 * kDeg, 30 * kDeg, false, true, 0.0);
  c[3] = addCoordinate(names[3], T, -0.05, 0.05, false, false, 0.0);
  c[4] = addCoordinate(names[4], T, -0.05, 0.05, false, false, 0.0);
  c[5] = addCoordinate(names[5], T, -0.05, 0.05, false, true, 0.0);
  setKneeAxes(j, c);
  m->joints.push_back(j);
  int knee_flex = -1;
  for (size_t i = 0; i < m->coordinates.size(); ++i)
    if (m->coordinates[i].name == "knee_flexion") knee_flex = int(i);
  model::CoordinateCoupler cf;
  cf.name = "patfem_flexion_path";
  cf.independents = {knee_flex};
  cf.dependent = c[0];
  cf.function = model::makeLinear(1.0, 0.0);
  m->couplers.push_back(cf);
  for (int i : {3, 4}) {
    model::CoordinateCoupler cc;
    cc.name = std::string(names[i]) + "_path";
    cc.independents = {knee_flex};
    cc.dependent = c[i];
    const std::vector<double>& y = i == 3 ? pf_tx : pf_ty;
    cc.function = model::makeSimmSpline(pf_knots, y);
    m->coordinates[c[i]].default_value = cc.function->calcValue(flex_default);
    m->couplers.push_back(cc);
  }
}

void Builder::setRanges() {
  for (const auto& [coordinate, range] : s.ranges) {
    const std::string& name = coordinate;  // C++17 lambdas cannot capture structured bindings (clang)
    auto it = std::find_if(m->coordinates.begin(), m->coordinates.end(),
                           [&](const model::Coordinate& c) { return c.name == name; });
    if (it == m->coordinates.end())
      throw InputError({s.setup_file, 0, "CoordinateRanges/Range[" + name + "]"}, "unknown coordinate '" + name + "'");
    const double unit = it->motion_type == model::MotionType::Rotational ? kDeg : 1.0;
    it->range_min = range.first * unit;
    it->range_max = range.second * unit;
  }
}

void Builder::addMarkers() {
  for (const KneeModelMarker& km : s.markers) {
    model::Marker mk;
    mk.name = km.name;
    int part = -1;
    for (int i = 0; i < 9; ++i)
      if (km.body == kKneeModelBodyNames[i]) part = i;
    mk.body = nb(part);
    if (!km.source.empty()) {
      const int sm = src->findMarker(km.source);
      if (sm < 0)
        throw InputError({s.setup_file, 0, "MarkerSet/Marker[" + km.name + "]/source"},
                         "expected a marker '" + km.source + "' in " + s.source_model_file + ", got none");
      const int sb = src->markers[sm].body;
      if (sb != parts.body[part])
        throw InputError({s.setup_file, 0, "MarkerSet/Marker[" + km.name + "]/body"},
                         "expected body '" + src->bodies[sb].name + "' (the source marker's), got '" + km.body + "'");
      mk.p_BM = part == kPatella ? Vector3d(X_P_patsrc * src->markers[sm].p_BM) : src->markers[sm].p_BM;
    }
    m->markers.push_back(mk);
  }
}

// The built model, driven by knee_flexion alone (couplers applied), must reproduce the seated
// path: both condyles on the insert and the button on the femoral component, also between knots.
void Builder::checkThroughModel() {
  sim::System sys(m);
  auto ws = sys.createWorkspace();
  const int fc = nb(kFemoral), tc = nb(kTray), pc = nb(kPatella), kf = m->findCoordinate("knee_flexion");
  for (int k = 0; k + 1 < nk; ++k) {
    for (double w : {0.0, 0.5}) {
      Eigen::VectorXd q = sys.getDefaultCoordinates();
      q[kf] = (1 - w) * flex_x[k] + w * flex_x[k + 1];
      for (const auto& cc : m->couplers) q[cc.dependent] = cc.scale_factor * cc.function->calcValue(q[cc.independents[0]]);
      sys.realizePosition(*ws, q);
      const Isometry3d X_GF = sys.getBodyPose(*ws, fc);
      double gap[2];
      seater->calcGaps(sys.getBodyPose(*ws, tc).inverse() * X_GF, 0.05, gap, nullptr);
      const double pg = button->calcGap(X_GF.inverse() * sys.getBodyPose(*ws, pc));
      double& tf = w == 0 ? rep.model_knot_gap : rep.model_midpoint_gap;
      double& pf = w == 0 ? rep.model_knot_patella_gap : rep.model_midpoint_patella_gap;
      tf = std::max({tf, std::abs(gap[0]), std::abs(gap[1])});
      pf = std::max(pf, std::abs(pg));
    }
  }
}

void Builder::writeReportLines() {
  const std::vector<double>& knots = s.flexion_knots;
  auto& L = rep.lines;
  char buf[512];
  auto add = [&](const char* f, auto... a) {
    std::snprintf(buf, sizeof buf, f, a...);
    L.push_back(buf);
  };
  add("frame check: source model's default knee pose puts the femoral component STL %.3f mm (medial) and "
      "%.3f mm (lateral) from the insert STL (negative: penetration)",
      rep.source_gap_medial * 1e3, rep.source_gap_lateral * 1e3);
  add("frame check: source pose minus seated pose: F origin (%.3f, %.3f, %.3f) mm in T, rotation %.4f deg",
      rep.source_minus_seated.x() * 1e3, rep.source_minus_seated.y() * 1e3, rep.source_minus_seated.z() * 1e3,
      rep.source_seated_angle / kDeg);
  add("frame check: femoral component superior axis vs femoral mechanical axis: %.2f deg sagittal (top anterior), "
      "%.2f deg coronal (top medial)",
      rep.femur_axis_flexion / kDeg, rep.femur_axis_coronal / kDeg);
  add("frame check: CT talus centroid minus source ankle centre, tray frame: (%.1f, %.1f, %.1f) mm; fibula top y = %.1f mm",
      rep.talus_minus_ankle.x() * 1e3, rep.talus_minus_ankle.y() * 1e3, rep.talus_minus_ankle.z() * 1e3,
      rep.fibula_top * 1e3);
  add("frame check: patella bone cut face x = %.3f mm (button back plane x = 0)", rep.patella_cut_offset * 1e3);
  add("seating: hinge cylinder R = %.2f mm; neutral (%.1f deg) gaps %.2e / %.2e m, hinge point in T (%.3f, %.3f, %.3f) mm",
      rep.hinge_radius * 1e3, s.neutral_flexion / kDeg, rep.neutral_gap_medial, rep.neutral_gap_lateral,
      rep.neutral_hinge_I.x() * 1e3, rep.neutral_hinge_I.y() * 1e3, rep.neutral_hinge_I.z() * 1e3);
  add("path: %d knots %.0f..%.0f deg; largest knot gap %.2e m; smoothing raises the hinge by at most %.2f um",
      nk, knots.front() / kDeg, knots.back() / kDeg, rep.max_knot_gap, rep.max_smoothing_height * 1e6);
  add("patella: button origin at zero flexion (%.2f, %.2f, %.2f) mm in F", p0.x() * 1e3, p0.y() * 1e3, p0.z() * 1e3);
  add("model check (knee_flexion only, couplers applied): largest |gap| at the knots %.2e m, between knots %.2e m; "
      "button largest |gap| %.2e m at the knots, %.2e m between",
      rep.model_knot_gap, rep.model_midpoint_gap, rep.model_knot_patella_gap, rep.model_midpoint_patella_gap);
  L.push_back("   flex(deg)  add(deg)  rot(deg)   tx(mm)   ty(mm)   tz(mm)  gapM(um) gapL(um)  dh(um)  pat_off(mm) gap@r0(mm)");
  for (const KneePathKnot& k : rep.knots)
    add("   %8.1f %9.3f %9.3f %8.3f %8.3f %8.3f %9.3f %8.3f %7.2f %11.3f %10.3f", k.q[0] / kDeg, k.q[1] / kDeg,
        k.q[2] / kDeg, k.q[3] * 1e3, k.q[4] * 1e3, k.q[5] * 1e3, k.gap_medial * 1e6, k.gap_lateral * 1e6,
        k.height_above_lowest * 1e6, k.patella_offset * 1e3, k.patella_gap * 1e3);
}

}  // namespace

KneeModelResult buildKneeModel(const KneeModelSetup& s) { return Builder(s).run(); }


void runKneeModelTool(const std::string& setup_path, const RunOptions& options) {
  const KneeModelSetup setup = readKneeModelSetup(setup_path);
  const KneeModelResult r = buildKneeModel(setup);
  model::OsimWriteOptions wo;
  wo.comment = {"Generated by kneesim: `kneesim run " + fs::path(setup_path).filename().string() +
                    "` (engine/tool/knee_model.cpp). Do not edit by hand: edit the setup file and regenerate.",
                "Derived from the University of Florida JW model (Knee Grand Challenge, Stanford/UF; see README.md)",
                "and the implant STL files of the 4th Knee Grand Challenge (Fregly et al. 2012)."};
  wo.credits = "kneesim knee model builder; source model " + fs::path(setup.source_model_file).filename().string();
  std::string csv;
  if (!setup.path_file.empty()) {
    std::ostringstream os;
    os.precision(10);
    os << "flexion_deg,knee_flexion_rad,knee_adduction_rad,knee_rotation_rad,knee_tx_m,knee_ty_m,knee_tz_m,"
          "gap_medial_m,gap_lateral_m,height_above_lowest_m,patella_offset_m,patella_gap_at_neutral_radius_m\n";
    for (const KneePathKnot& k : r.report.knots) {
      os << k.flexion / kDeg;
      for (double v : k.q) os << "," << v;
      os << "," << k.gap_medial << "," << k.gap_lateral << "," << k.height_above_lowest << "," << k.patella_offset
         << "," << k.patella_gap << "\n";
    }
    csv = os.str();
  }
  model::writeOsim(setup.output_model_file, *r.model, wo);
  if (!csv.empty()) writeFileAtomically(setup.path_file, [&](std::ostream& os) { os << csv; });
  if (options.out) {
    for (const std::string& l : r.report.lines) *options.out << l << "\n";
    *options.out << "wrote " << setup.output_model_file << "\n";
    if (!csv.empty()) *options.out << "wrote " << setup.path_file << "\n";
  }
}

}  // namespace kneesim::tool
