// Distance map and contact area speed on JW's implant (data/kgc4-jw): the insert's
// articular vertices (3,260 of its 20,870-triangle mesh) against the femoral component (80,774
// triangles), single thread, over two motions:
//  - sweep: the paper's hinge kinematics from 0 to 70 degrees of flexion in 1-degree steps
//    (seated at every angle), run forward then backward as one continuous motion (141 frames);
//  - ngait_og3: the eKnee goniometer of trial ngait_og3 (291 frames at 120 Hz, 2.8-64.7 degrees),
//    each pose interpolated between the seated poses of the two nearest whole degrees.
//
//  - BM_SameFrames/<motion> (one iteration): every distance provider over the same frames in the
//    same run, from a fresh context: "fcl" (exact), "fcl_sdf" (cached grid, approximate: its first
//    pass pays for filling the grid, a second pass over the same frames is timed separately),
//    "fcl_pruned" (FCL's own query per point, bounded), "fcl_naive" (one unbounded FCL query per
//    point: the baseline of the speed-ups) and the engine's exact MeshDistance. Prints a table of
//    ms/frame (thread CPU time, and wall time: the machine may be shared), points/s, speed-up over
//    fcl_naive in CPU time, the largest error against the exact distances (fcl_naive's) of every
//    value within 4 mm, and the number of points beyond 4 mm put on the wrong side.
//  - BM_DistanceMap/<provider>: Google Benchmark's own timing, one sweep frame per iteration
//    (frames cycle from 0 degrees, so providers with few iterations see mostly low flexion, and
//    "fcl_sdf" is measured mostly with a filled grid).
//  - BM_ContactAreaSameFrames: the whole contact-area frame (distance map to the search radius,
//    partial-triangle areas at 4 mm and at 1, 2, 3, 5 and 6 mm, compartments, centroids) with
//    "fcl", "fcl_sdf" and MeshDistance over the sweep; prints ms/frame and how far S, S_medial,
//    S_lateral, S@1mm..S@6mm and dmin from "fcl_sdf" and MeshDistance are from "fcl".
#include <benchmark/benchmark.h>
#include <dlfcn.h>
#include <time.h>

#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <memory>

#include "contact/condyle.hpp"
#include "contact/contact_area.hpp"
#include "contact/distance.hpp"
#include "contact/mesh_distance.hpp"
#include "contact/seating.hpp"
#include "io/knee_forces.hpp"
#include "plugin/registry.hpp"

namespace {

namespace contact = kneesim::contact;
namespace io = kneesim::io;
using Eigen::Vector3d;

const std::string kData = std::string(KNEESIM_DATA_DIR) + "/kgc4-jw/";
constexpr double kSearch = 4e-3;  // the paper's threshold

struct Fixture {
  io::TriangleMesh femur, insert;
  std::vector<Vector3d> points_I;        // insert articular vertices
  std::vector<Eigen::Isometry3d> sweep;  // X_FI per frame, 0..70..0 deg
  std::vector<Eigen::Isometry3d> gait;   // X_FI per frame of ngait_og3
  kneesim::plugin::Registry registry;
};

// The pose between two seated poses (rotation slerp, translation lerp).
Eigen::Isometry3d interpolate(const Eigen::Isometry3d& a, const Eigen::Isometry3d& b, double s) {
  Eigen::Isometry3d X = Eigen::Isometry3d::Identity();
  X.linear() = Eigen::Quaterniond(a.linear()).slerp(s, Eigen::Quaterniond(b.linear())).toRotationMatrix();
  X.translation() = (1 - s) * a.translation() + s * b.translation();
  return X;
}

Fixture* getFixture() {
  static std::unique_ptr<Fixture> f = [] {
    std::unique_ptr<Fixture> x;
    if (!std::filesystem::exists(kData + "implant/femoral_component.stl")) return x;
    x = std::make_unique<Fixture>();
    x->femur = io::readStl(kData + "implant/femoral_component.stl", {1.0, true, 0.01, 0.5});
    x->insert = io::readStl(kData + "implant/tibial_insert.stl", {1.0, true, 0.01, 0.5});
    const contact::CondyleFits fits = contact::fitCondyles(x->femur, contact::ArticularSelection{});
    const contact::SeatingSetup setup = contact::makeSeatingSetup(x->femur, x->insert, fits.both.cylinder);
    x->points_I = contact::getPositions(setup.insert_medial_I);
    for (const Vector3d& p : contact::getPositions(setup.insert_lateral_I)) x->points_I.push_back(p);
    contact::Seater seater(setup);
    std::vector<double> flexions;
    for (int deg = 0; deg <= 70; ++deg) flexions.push_back(deg * contact::kDegree);
    const auto seats = seater.calcHingeKinematics(flexions);
    for (const auto& s : seats) x->sweep.push_back(s.X_IF.inverse());
    for (int k = int(seats.size()) - 2; k >= 0; --k) x->sweep.push_back(seats[size_t(k)].X_IF.inverse());
    const io::KneeForces kf = io::readKneeForces(kData + "knee-forces/jw_ngait_og3_knee_forces.csv");
    double lo = 1e9, hi = -1e9;
    for (double deg : kf.goniometer) {
      const double c = std::clamp(deg, 0.0, 70.0);
      const int k = std::min(69, int(c));
      x->gait.push_back(interpolate(seats[size_t(k)].X_IF, seats[size_t(k + 1)].X_IF, c - k).inverse());
      lo = std::min(lo, deg);
      hi = std::max(hi, deg);
    }
    x->registry.loadPlugin("distance_fcl");
    std::printf("fixture: %zu insert articular vertices, femoral component %d triangles; sweep %zu frames "
                "(0..70..0 deg), ngait_og3 %zu frames (%.1f..%.1f deg)\n",
                x->points_I.size(), x->femur.getNumTriangles(), x->sweep.size(), x->gait.size(), lo, hi);
    return x;
  }();
  return f.get();
}

double threadCpuSeconds() {
  timespec t;
  clock_gettime(CLOCK_THREAD_CPUTIME_ID, &t);
  return double(t.tv_sec) + 1e-9 * double(t.tv_nsec);
}

// CPU and wall seconds of a callable.
template <class F>
std::pair<double, double> timed(F&& f) {
  const auto w0 = std::chrono::steady_clock::now();
  const double c0 = threadCpuSeconds();
  f();
  const double c1 = threadCpuSeconds();
  const auto w1 = std::chrono::steady_clock::now();
  return {c1 - c0, std::chrono::duration<double>(w1 - w0).count()};
}

// A distance map over frames: a provider's DistanceField, or the engine's MeshDistance.
class Map {
 public:
  Map(Fixture& f, const std::string& name) : name_(name), f_(f) {
    if (name == "MeshDistance")
      md_ = std::make_unique<contact::MeshDistance>(f.femur);
    else
      field_ = std::make_unique<contact::DistanceField>(f.registry.getDistanceProvider(name), f.femur, f.points_I);
  }
  void calc(const Eigen::Isometry3d& X_FI, std::vector<double>& d) {
    if (field_) return field_->calcDistances(X_FI, kSearch, d);
    d.resize(f_.points_I.size());
    for (size_t i = 0; i < d.size(); ++i)
      d[i] = md_->calcSignedDistance(X_FI * f_.points_I[i], kSearch, q_) ? q_.distance : HUGE_VAL;
  }
  const contact::DistanceField* getField() const { return field_.get(); }

 private:
  std::string name_;
  Fixture& f_;
  std::unique_ptr<contact::DistanceField> field_;
  std::unique_ptr<contact::MeshDistance> md_;
  contact::MeshDistanceQuery q_;
};

// The "fcl_sdf" grid counters (see plugins/distance_fcl), or empty.
std::vector<long long> getSdfStats(const Fixture& f, const contact::DistanceField& field) {
  std::vector<long long> v(10, 0);
  void* h = dlopen(f.registry.findOrigin("fcl_sdf").c_str(), RTLD_NOW | RTLD_NOLOAD);
  using Fn = int (*)(void*, long long*, int);
  Fn fn = h ? reinterpret_cast<Fn>(dlsym(h, "kneesim_distance_fcl_get_sdf_stats")) : nullptr;
  v.resize(fn ? size_t(fn(field.getProviderContext(), v.data(), 10)) : 0);
  if (h) dlclose(h);
  return v;
}

struct Row {
  std::string name;
  double cpu = 0, wall = 0;  // seconds over all frames
  double max_error = 0;      // m, points within kSearch
  long wrong_side = 0;       // points beyond kSearch reported on the wrong side
};

void BM_SameFrames(benchmark::State& state, bool gait) {
  Fixture* f = getFixture();
  if (!f) return state.SkipWithError("kgc4-jw data not found");
  const std::vector<Eigen::Isometry3d>& frames = gait ? f->gait : f->sweep;
  const double n_frames = double(frames.size()), n_points = double(f->points_I.size());
  for (auto _ : state) {
    // The exact reference: fcl_naive's distances (one unbounded query per point), also the
    // baseline of the speed-ups.
    std::vector<std::vector<double>> ref(frames.size());
    std::vector<Row> rows;
    const auto run = [&](const std::string& label, Map& map, bool check) {
      Row r;
      r.name = label;
      std::vector<double> d;
      for (size_t k = 0; k < frames.size(); ++k) {
        const auto t = timed([&] { map.calc(frames[k], d); });
        r.cpu += t.first;
        r.wall += t.second;
        if (!check) {
          ref[k] = d;
          continue;
        }
        for (size_t i = 0; i < d.size(); ++i) {
          const double e = ref[k][i];
          // Within 4 mm (by the truth or by the provider: an approximate value may cross 4 mm
          // within its tolerance) the values are compared; beyond it only the side counts.
          if (std::abs(e) <= kSearch || std::abs(d[i]) <= kSearch)
            r.max_error = std::max(r.max_error, std::abs(d[i] - e));
          else if ((e > 0) != (d[i] > 0))
            ++r.wrong_side;
        }
      }
      rows.push_back(r);
    };
    {
      Map naive(*f, "fcl_naive");
      run("fcl_naive", naive, false);
    }
    {
      Map fcl(*f, "fcl");
      run("fcl", fcl, true);
    }
    std::vector<long long> sdf_first, sdf_warm;
    {
      Map sdf(*f, "fcl_sdf");
      run("fcl_sdf (first pass)", sdf, true);
      sdf_first = getSdfStats(*f, *sdf.getField());
      run("fcl_sdf (second pass)", sdf, true);
      sdf_warm = getSdfStats(*f, *sdf.getField());
    }
    {
      Map pruned(*f, "fcl_pruned");
      run("fcl_pruned", pruned, true);
    }
    {
      Map md(*f, "MeshDistance");
      run("MeshDistance", md, true);
    }
    const Row& base = rows[0];
    std::printf("\n%s: %zu frames x %d points, distances within %.0f mm exact or within tolerance\n",
                gait ? "ngait_og3 (goniometer)" : "sweep 0..70..0 deg", frames.size(), int(n_points), kSearch * 1e3);
    std::printf("  %-22s %10s %10s %12s %10s %14s %10s\n", "provider", "cpu ms/fr", "wall ms/fr", "points/s",
                "speed-up", "max |err| um", "wrong side");
    for (const Row& r : rows)
      std::printf("  %-22s %10.3f %10.3f %12.3g %9.1fx %14.3g %10ld\n", r.name.c_str(), 1e3 * r.cpu / n_frames,
                  1e3 * r.wall / n_frames, n_points * n_frames / r.cpu, base.cpu / r.cpu, r.max_error * 1e6,
                  r.wrong_side);
    if (sdf_first.size() >= 8 && sdf_warm.size() >= 8) {
      const long long pts_first = sdf_first[5] + sdf_first[6] + sdf_first[7];
      std::printf("  fcl_sdf grid after the first pass: %lld nodes evaluated exactly (%lld blocks, %.1f MB), %lld cells "
                  "(%lld exact, %lld beyond the band); points: %.1f%% interpolated, %.1f%% exact, %.1f%% far\n",
                  sdf_first[0], sdf_first[9], double(sdf_first[9]) * 7.7e-3, sdf_first[2], sdf_first[3], sdf_first[4],
                  100.0 * double(sdf_first[5]) / double(pts_first), 100.0 * double(sdf_first[6]) / double(pts_first),
                  100.0 * double(sdf_first[7]) / double(pts_first));
      std::printf("  second pass: %lld more nodes\n", sdf_warm[0] - sdf_first[0]);
    }
    state.counters["naive_ms"] = 1e3 * base.cpu / n_frames;
    state.counters["fcl_ms"] = 1e3 * rows[1].cpu / n_frames;
    state.counters["fcl_speedup"] = base.cpu / rows[1].cpu;
    state.counters["sdf_first_ms"] = 1e3 * rows[2].cpu / n_frames;
    state.counters["sdf_warm_ms"] = 1e3 * rows[3].cpu / n_frames;
    state.counters["sdf_warm_speedup"] = base.cpu / rows[3].cpu;
    state.counters["sdf_max_err_um"] = std::max(rows[2].max_error, rows[3].max_error) * 1e6;
  }
}
BENCHMARK_CAPTURE(BM_SameFrames, sweep, false)->Unit(benchmark::kMillisecond)->Iterations(1);
BENCHMARK_CAPTURE(BM_SameFrames, ngait_og3, true)->Unit(benchmark::kMillisecond)->Iterations(1);

void BM_DistanceMap(benchmark::State& state, const std::string& provider) {
  Fixture* f = getFixture();
  if (!f) return state.SkipWithError("kgc4-jw data not found");
  Map map(*f, provider);
  std::vector<double> d;
  size_t frame = 0;
  for (auto _ : state) {
    map.calc(f->sweep[frame], d);
    frame = (frame + 1) % f->sweep.size();
  }
  state.SetItemsProcessed(int64_t(state.iterations()) * int64_t(f->points_I.size()));
}
BENCHMARK_CAPTURE(BM_DistanceMap, fcl, std::string("fcl"))->Unit(benchmark::kMillisecond);
BENCHMARK_CAPTURE(BM_DistanceMap, fcl_sdf, std::string("fcl_sdf"))->Unit(benchmark::kMillisecond);
BENCHMARK_CAPTURE(BM_DistanceMap, fcl_naive, std::string("fcl_naive"))->Unit(benchmark::kMillisecond);
BENCHMARK_CAPTURE(BM_DistanceMap, MeshDistance, std::string("MeshDistance"))->Unit(benchmark::kMillisecond);

void BM_ContactAreaSameFrames(benchmark::State& state) {
  Fixture* f = getFixture();
  if (!f) return state.SkipWithError("kgc4-jw data not found");
  contact::ContactAreaOptions o;
  o.extra_thresholds = {1e-3, 2e-3, 3e-3, 5e-3, 6e-3};
  for (auto _ : state) {
    const char* names[] = {"fcl", "fcl_sdf", "MeshDistance"};
    std::vector<std::vector<contact::ContactFrame>> out(3);
    std::printf("\ncontact area per frame (distances to the search radius, S at 4 mm and 1, 2, 3, 5, 6 mm), sweep:\n");
    for (int p = 0; p < 3; ++p) {
      const kneesim_distance_provider* provider =
          p < 2 ? &f->registry.getDistanceProvider(names[p]) : nullptr;  // nullptr: MeshDistance
      const contact::ContactAreaCalculator calc(f->insert, f->femur, o, provider);
      auto ws = calc.createWorkspace();
      out[size_t(p)].resize(f->sweep.size());
      double cpu[2] = {0, 0};
      for (int pass = 0; pass < 2; ++pass)
        for (size_t k = 0; k < f->sweep.size(); ++k)
          cpu[pass] += timed([&] { calc.calcFrame(*ws, f->sweep[k].inverse(), out[size_t(p)][k]); }).first;
      double dS = 0, dSml = 0, dSx = 0, ddmin = 0, S_max = 0;
      for (size_t k = 0; k < f->sweep.size(); ++k) {
        const contact::ContactFrame &a = out[size_t(p)][k], &b = out[0][k];
        S_max = std::max(S_max, b.S);
        dS = std::max(dS, std::abs(a.S - b.S));
        dSml = std::max({dSml, std::abs(a.S_medial - b.S_medial), std::abs(a.S_lateral - b.S_lateral)});
        for (size_t e = 0; e < a.S_extra.size(); ++e) dSx = std::max(dSx, std::abs(a.S_extra[e] - b.S_extra[e]));
        ddmin = std::max(ddmin, std::abs(a.dmin - b.dmin));
      }
      const double n = double(f->sweep.size());
      std::printf("  %-12s search %.2f mm: %.3f ms/frame (first pass), %.3f (second); vs fcl: max |dS| %.3f mm^2 "
                  "(S up to %.0f), |dS_medial/lateral| %.3f, |dS@1..6mm| %.3f, |d dmin| %.2f um\n",
                  names[p], calc.getSearchRadius() * 1e3, 1e3 * cpu[0] / n, 1e3 * cpu[1] / n, dS * 1e6, S_max * 1e6,
                  dSml * 1e6, dSx * 1e6, ddmin * 1e6);
      state.counters[std::string(names[p]) + "_ms"] = 1e3 * cpu[0] / n;
      if (p > 0) state.counters[std::string(names[p]) + "_max_dS_mm2"] = std::max(dS, dSx) * 1e6;
    }
  }
}
BENCHMARK(BM_ContactAreaSameFrames)->Unit(benchmark::kMillisecond)->Iterations(1);

}  // namespace

BENCHMARK_MAIN();
