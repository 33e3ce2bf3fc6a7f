#include "contact/contact_area.hpp"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <limits>

#include "core/error.hpp"

namespace kneesim::contact {

namespace {

using Eigen::Vector3d;

constexpr double kInf = std::numeric_limits<double>::infinity();
constexpr double kNaN = std::numeric_limits<double>::quiet_NaN();
constexpr int kMaxPolygon = 8;  // a triangle clipped by two planes has at most 5 corners

// Keeps the part of the convex polygon (in, n) where the per-corner value s is negative (s is
// linear over the polygon); returns the corner count of the result in out.
int clipNegative(const Vector3d* in, const double* s, int n, Vector3d* out) {
  int m = 0;
  for (int i = 0; i < n; ++i) {
    const int j = (i + 1) % n;
    const bool in_i = s[i] < 0, in_j = s[j] < 0;
    if (in_i) out[m++] = in[i];
    if (in_i != in_j) out[m++] = in[i] + (s[i] / (s[i] - s[j])) * (in[j] - in[i]);
  }
  return m;
}

// Area and first moment (area x centroid) of a planar convex polygon.
void polygonMoments(const Vector3d* p, int n, double& area, Vector3d& moment) {
  area = 0;
  moment.setZero();
  for (int i = 1; i + 1 < n; ++i) {
    const double a = 0.5 * (p[i] - p[0]).cross(p[i + 1] - p[0]).norm();
    area += a;
    moment += a * (p[0] + p[i] + p[i + 1]) / 3.0;
  }
}

bool isRigid(const Eigen::Isometry3d& X) {
  const Eigen::Matrix3d R = X.linear();
  return X.matrix().allFinite() && (R.transpose() * R - Eigen::Matrix3d::Identity()).cwiseAbs().maxCoeff() < 1e-6 &&
         R.determinant() > 0;
}

}  // namespace

const char* toString(AreaRule rule) {
  return rule == AreaRule::vertex_areas ? "vertex_areas" : "partial_triangles";
}

AreaRule parseAreaRule(const std::string& text, const SourceLocation& where) {
  if (text == "partial_triangles") return AreaRule::partial_triangles;
  if (text == "vertex_areas") return AreaRule::vertex_areas;
  throw InputError(where, "expected partial_triangles or vertex_areas, got '" + text + "'");
}

std::string areaChannelName(double t) {
  char buf[64];
  std::snprintf(buf, sizeof buf, "S@%gmm", std::round(t * 1e3 * 1e6) / 1e6);
  return buf;
}

ContactAreaWorkspace::~ContactAreaWorkspace() = default;

ContactAreaCalculator::ContactAreaCalculator(io::TriangleMesh insert, io::TriangleMesh femur, ContactAreaOptions options,
                                             const kneesim_distance_provider* provider)
    : insert_(std::move(insert)), femur_(std::move(femur)), options_(std::move(options)), provider_(provider) {
  const SourceLocation here{insert_.source_file, 0, "contact area"};
  auto checkThreshold = [&](double t) {
    if (!std::isfinite(t) || t < 0)
      throw InputError(here, "expected a contact threshold >= 0 m, got " + std::to_string(t));
  };
  checkThreshold(options_.threshold);
  for (double t : options_.extra_thresholds) checkThreshold(t);
  if (femur_.getNumTriangles() == 0)
    throw InputError({femur_.source_file, 0, ""}, "expected a femoral component mesh, got no triangles");

  const InsertArticularVertices sel =
      selectInsertArticularVertices(insert_, options_.insert_directions, options_.max_normal_angle);
  split_point_ = sel.split_point;
  medial_ = sel.medial_direction;
  vertices_ = sel.medial;
  vertices_.insert(vertices_.end(), sel.lateral.begin(), sel.lateral.end());
  n_medial_ = int(sel.medial.size());
  std::vector<int> local(insert_.vertices.size(), -1);
  for (size_t i = 0; i < vertices_.size(); ++i) local[size_t(vertices_[i])] = int(i);
  points_I_.reserve(vertices_.size());
  for (int v : vertices_) points_I_.push_back(insert_.vertices[size_t(v)]);

  vertex_area_.assign(vertices_.size(), 0.0);
  std::vector<double> longest(vertices_.size(), 0.0);  // longest incident articular edge
  for (const Eigen::Vector3i& t : insert_.triangles) {
    const Eigen::Vector3i l(local[size_t(t[0])], local[size_t(t[1])], local[size_t(t[2])]);
    if (l.minCoeff() < 0) continue;
    TriangleData td;
    td.v = l;
    const Vector3d &a = points_I_[size_t(l[0])], &b = points_I_[size_t(l[1])], &c = points_I_[size_t(l[2])];
    td.area = 0.5 * (b - a).cross(c - a).norm();
    td.centroid = (a + b + c) / 3.0;
    int medial = 0;
    for (int k = 0; k < 3; ++k) medial += l[k] < n_medial_;
    td.side = medial == 3 ? 1 : (medial == 0 ? -1 : 0);
    for (int k = 0; k < 3; ++k) {
      const double e = (points_I_[size_t(l[(k + 1) % 3])] - points_I_[size_t(l[k])]).norm();
      longest[size_t(l[k])] = std::max(longest[size_t(l[k])], e);
      longest[size_t(l[(k + 1) % 3])] = std::max(longest[size_t(l[(k + 1) % 3])], e);
    }
    for (int k = 0; k < 3; ++k) vertex_area_[size_t(l[k])] += td.area / 3.0;
    area_total_ += td.area;
    triangles_.push_back(l);
    tri_.push_back(td);
  }
  if (tri_.empty())
    throw InputError(here, "expected articular triangles (all three vertices facing up and exposed), got none");
  // Compartment areas of the articular surface, splitting the triangles that cross the plane.
  for (const TriangleData& td : tri_) {
    if (td.side != 0) {
      (td.side > 0 ? area_medial_ : area_lateral_) += td.area;
      continue;
    }
    Vector3d p[3], poly[kMaxPolygon];
    double s[3], area;
    Vector3d moment;
    for (int k = 0; k < 3; ++k) {
      p[k] = points_I_[size_t(td.v[k])];
      s[k] = -medial_.dot(p[k] - split_point_);
    }
    polygonMoments(poly, clipNegative(p, s, 3, poly), area, moment);
    area_medial_ += area;
    area_lateral_ += td.area - area;
  }
  double t_max = options_.threshold;
  for (double t : options_.extra_thresholds) t_max = std::max(t_max, t);
  // A vertex of a triangle that a threshold crosses is at most one of its edges farther than
  // t_max. A few long edges (JW's insert: median 1.05 mm, 99.9th percentile 6.9 mm) should not
  // widen the search of every vertex: the 10% of vertices with the longest edges get their own.
  std::vector<double> sorted = longest;
  std::sort(sorted.begin(), sorted.end());
  const double l0 = sorted[std::min(sorted.size() - 1, size_t(0.9 * double(sorted.size())))];
  radius_[0] = t_max + 1.01 * l0 + 1e-6;
  radius_[1] = t_max + 1.01 * sorted.back() + 1e-6;
  vertex_radius_.resize(vertices_.size());
  for (size_t i = 0; i < vertices_.size(); ++i) {
    const int g = longest[i] > l0 ? 1 : 0;
    group_[g].push_back(int(i));
    vertex_radius_[i] = radius_[g];
  }
  if (!provider_) exact_ = std::make_unique<MeshDistance>(femur_);
}

ContactAreaCalculator::~ContactAreaCalculator() = default;

double ContactAreaCalculator::getArticularArea(CondyleSide side) const {
  return side == CondyleSide::medial ? area_medial_ : side == CondyleSide::lateral ? area_lateral_ : area_total_;
}

std::string ContactAreaCalculator::getDistanceMethod() const {
  return provider_ ? std::string(provider_->name) : std::string("MeshDistance");
}

std::unique_ptr<ContactAreaWorkspace> ContactAreaCalculator::createWorkspace() const {
  std::unique_ptr<ContactAreaWorkspace> ws(new ContactAreaWorkspace);
  for (int g = 0; g < 2; ++g) {
    ws->buffer_[g].assign(group_[g].size(), 0.0);
    if (!provider_ || group_[g].empty()) continue;
    std::vector<Vector3d> points;
    for (int i : group_[g]) points.push_back(points_I_[size_t(i)]);
    ws->field_[g] = std::make_unique<DistanceField>(*provider_, femur_, points);
  }
  ws->distance_.assign(vertices_.size(), 0.0);
  ws->clamped_.assign(vertices_.size(), 0.0);
  return ws;
}

void ContactAreaCalculator::accumulate(const double* d, double t, bool split, ContactFrame* frame,
                                       double& total) const {
  total = 0;
  double area_side[2] = {0, 0};  // medial, lateral
  Vector3d moment_side[2] = {Vector3d::Zero(), Vector3d::Zero()};
  const auto add = [&](int side, double a, const Vector3d& m) {
    area_side[side] += a;
    moment_side[side] += m;
  };
  if (options_.rule == AreaRule::vertex_areas) {
    for (size_t i = 0; i < vertices_.size(); ++i)
      if (d[i] < t) {
        total += vertex_area_[i];
        if (split) add(int(i) < n_medial_ ? 0 : 1, vertex_area_[i], vertex_area_[i] * points_I_[i]);
      }
  } else {
    Vector3d p[3], poly[kMaxPolygon], half[kMaxPolygon];
    double s[kMaxPolygon];
    for (const TriangleData& td : tri_) {
      const double d0 = d[td.v[0]], d1 = d[td.v[1]], d2 = d[td.v[2]];
      if (d0 >= t && d1 >= t && d2 >= t) continue;
      const bool whole = d0 < t && d1 < t && d2 < t;
      if (whole && (td.side != 0 || !split)) {
        total += td.area;
        if (split) add(td.side > 0 ? 0 : 1, td.area, td.area * td.centroid);
        continue;
      }
      for (int k = 0; k < 3; ++k) p[k] = points_I_[size_t(td.v[k])];
      int n = 3;
      if (whole) {
        for (int k = 0; k < 3; ++k) poly[k] = p[k];
      } else {
        const double sd[3] = {d0 - t, d1 - t, d2 - t};
        n = clipNegative(p, sd, 3, poly);
      }
      double area;
      Vector3d moment;
      polygonMoments(poly, n, area, moment);
      total += area;
      if (!split) continue;
      if (td.side != 0) {
        add(td.side > 0 ? 0 : 1, area, moment);
        continue;
      }
      // Crossing the medial/lateral plane: the lateral part is where the medial coordinate is
      // negative, the medial part the rest.
      for (int k = 0; k < n; ++k) s[k] = medial_.dot(poly[k] - split_point_);
      double area_l;
      Vector3d moment_l;
      polygonMoments(half, clipNegative(poly, s, n, half), area_l, moment_l);
      add(1, area_l, moment_l);
      add(0, area - area_l, moment - moment_l);
    }
  }
  if (split) {
    frame->S_medial = area_side[0];
    frame->S_lateral = area_side[1];
    frame->centroid_medial =
        area_side[0] > 0 ? Vector3d(moment_side[0] / area_side[0]) : Vector3d::Constant(kNaN);
    frame->centroid_lateral =
        area_side[1] > 0 ? Vector3d(moment_side[1] / area_side[1]) : Vector3d::Constant(kNaN);
  }
}

void ContactAreaCalculator::calcFrame(ContactAreaWorkspace& ws, const Eigen::Isometry3d& X_IF,
                                      ContactFrame& out) const {
  if (!isRigid(X_IF))
    throw InputError({insert_.source_file, 0, "contact area"},
                     "expected a rigid pose X_IF of the femoral component, got a non-finite or non-orthonormal one");
  const Eigen::Isometry3d X_FI = X_IF.inverse(Eigen::Isometry);
  const int n = int(vertices_.size());
  std::vector<double>& d = ws.distance_;
  const auto compute = [&](bool unbounded) {
    for (int g = 0; g < 2; ++g) {
      const double radius = unbounded ? kInf : radius_[g];
      if (ws.field_[g]) {
        ws.field_[g]->calcDistances(X_FI, radius, ws.buffer_[g]);
        for (size_t j = 0; j < group_[g].size(); ++j) d[size_t(group_[g][j])] = ws.buffer_[g][j];
        continue;
      }
      if (provider_) continue;  // an empty group
      MeshDistanceQuery q;
      for (int i : group_[g]) {
        const Vector3d p = X_FI * points_I_[size_t(i)];
        // A bounded search cannot tell a far point's side: search again without a bound.
        d[size_t(i)] = exact_->calcSignedDistance(p, radius, q) ? q.distance : exact_->calcSignedDistance(p);
      }
    }
  };
  compute(false);
  const auto minOver = [&](int begin, int end) {
    double m = kInf;
    for (int i = begin; i < end; ++i) m = std::min(m, d[size_t(i)]);
    return m;
  };
  out.dmin_medial = minOver(0, n_medial_);
  out.dmin_lateral = minOver(n_medial_, n);
  if (!std::isfinite(out.dmin_medial) || !std::isfinite(out.dmin_lateral)) {
    // A whole compartment beyond the search radius (lifted off, or sunk deep): its smallest
    // distance needs every distance exact.
    compute(true);
    out.dmin_medial = minOver(0, n_medial_);
    out.dmin_lateral = minOver(n_medial_, n);
  }
  out.dmin = std::min(out.dmin_medial, out.dmin_lateral);

  // Values beyond the search radius only matter by their side: no threshold crosses their triangles.
  for (int i = 0; i < n; ++i)
    ws.clamped_[size_t(i)] = std::clamp(d[size_t(i)], -vertex_radius_[size_t(i)], vertex_radius_[size_t(i)]);
  accumulate(ws.clamped_.data(), options_.threshold, true, &out, out.S);
  out.S_extra.resize(options_.extra_thresholds.size());
  for (size_t k = 0; k < options_.extra_thresholds.size(); ++k)
    accumulate(ws.clamped_.data(), options_.extra_thresholds[k], false, nullptr, out.S_extra[k]);
}

void calcAreaDerivatives(ContactSeries& series) {
  const size_t n = series.frames.size();
  KNEESIM_CHECK(series.time.size() == n, "contact series: one time per frame");
  series.dS_dt.assign(n, 0.0);
  series.dS_medial_dt.assign(n, 0.0);
  series.dS_lateral_dt.assign(n, 0.0);
  if (n < 2) return;
  for (size_t i = 0; i < n; ++i) {
    const size_t a = i == 0 ? 0 : i - 1, b = i + 1 == n ? n - 1 : i + 1;
    const double dt = series.time[b] - series.time[a];
    const auto rate = [&](double ContactFrame::*field) {
      return dt > 0 ? (series.frames[b].*field - series.frames[a].*field) / dt : kNaN;
    };
    series.dS_dt[i] = rate(&ContactFrame::S);
    series.dS_medial_dt[i] = rate(&ContactFrame::S_medial);
    series.dS_lateral_dt[i] = rate(&ContactFrame::S_lateral);
  }
}

ContactSeries calcContactSeries(const ContactAreaCalculator& calculator, ContactAreaWorkspace& ws,
                                const std::vector<double>& time, const std::vector<Eigen::Isometry3d>& X_IF,
                                const std::function<void(int, int)>& progress,
                                const std::function<void(int, const ContactAreaWorkspace&)>& on_frame) {
  KNEESIM_CHECK(time.size() == X_IF.size(), "contact series: one pose per time");
  ContactSeries series;
  series.time = time;
  series.extra_thresholds = calculator.getOptions().extra_thresholds;
  series.frames.resize(X_IF.size());
  const int total = int(X_IF.size());
  for (int k = 0; k < total; ++k) {
    series.frames[size_t(k)].S_extra.resize(series.extra_thresholds.size());
    calculator.calcFrame(ws, X_IF[size_t(k)], series.frames[size_t(k)]);
    if (on_frame) on_frame(k, ws);
    if (progress && (k % 10 == 9 || k + 1 == total)) progress(k + 1, total);
  }
  calcAreaDerivatives(series);
  return series;
}

std::vector<std::pair<std::string, std::vector<double>>> getContactChannels(const ContactSeries& series) {
  std::vector<std::pair<std::string, std::vector<double>>> c;
  const auto column = [&](const std::string& name, const std::function<double(const ContactFrame&)>& get) {
    std::vector<double> v;
    v.reserve(series.frames.size());
    for (const ContactFrame& f : series.frames) v.push_back(get(f));
    c.emplace_back(name, std::move(v));
  };
  c.emplace_back("time", series.time);
  column("S", [](const ContactFrame& f) { return f.S; });
  column("S_medial", [](const ContactFrame& f) { return f.S_medial; });
  column("S_lateral", [](const ContactFrame& f) { return f.S_lateral; });
  column("dmin", [](const ContactFrame& f) { return f.dmin; });
  column("dmin_medial", [](const ContactFrame& f) { return f.dmin_medial; });
  column("dmin_lateral", [](const ContactFrame& f) { return f.dmin_lateral; });
  const char* axes[3] = {"cx", "cy", "cz"};
  for (int k = 0; k < 3; ++k)
    column(std::string(axes[k]) + "_medial", [k](const ContactFrame& f) { return f.centroid_medial[k]; });
  for (int k = 0; k < 3; ++k)
    column(std::string(axes[k]) + "_lateral", [k](const ContactFrame& f) { return f.centroid_lateral[k]; });
  for (size_t e = 0; e < series.extra_thresholds.size(); ++e)
    column(areaChannelName(series.extra_thresholds[e]), [e](const ContactFrame& f) { return f.S_extra[e]; });
  c.emplace_back("dS_dt", series.dS_dt);
  c.emplace_back("dS_medial_dt", series.dS_medial_dt);
  c.emplace_back("dS_lateral_dt", series.dS_lateral_dt);
  return c;
}

}  // namespace kneesim::contact
