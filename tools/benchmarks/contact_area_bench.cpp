// Distance map and contact area speed on JW's implant (needs ../shared/data): the insert's
// articular vertices (3,260 of its 20,870-triangle mesh) against the femoral component (80,774
// triangles), over the paper's hinge kinematics from 0 to 70 degrees of flexion in 1-degree steps
// (seated at every angle), run forward then backward as a continuous motion.
//
//  - BM_DistanceMap/<provider>: one frame per iteration, single thread: "fcl" (pruned, culled,
//    coherent), "fcl_naive" (one unbounded FCL query per vertex) and the engine's own MeshDistance
//    with the same search radius. Counters: near = vertices within the radius per frame,
//    fcl_queries = FCL queries per frame.
//  - BM_FclVsNaiveSameFrames: both FCL maps over the same 141 frames in the same run, timed
//    back to back; prints ms per frame of each and the speed-up, and checks they agree.
//  - BM_ContactAreaFrame: the whole per-frame contact-area computation (distance map + partial
//    triangle areas at 4 thresholds + compartments and centroids) with the "fcl" provider.
#include <benchmark/benchmark.h>
#include <dlfcn.h>

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
#include "plugin/registry.hpp"

namespace {

namespace contact = kneesim::contact;
namespace io = kneesim::io;
using Eigen::Vector3d;

const std::string kImplant = std::string(KNEESIM_DATA_DIR) + "/kgc4-jw/implant/";
constexpr double kSearch = 4e-3;  // the paper's threshold

struct Fixture {
  io::TriangleMesh femur, insert;
  std::vector<Vector3d> points_I;           // insert articular vertices
  std::vector<Eigen::Isometry3d> X_FI;      // per frame, 0..70..0 deg
  kneesim::plugin::Registry registry;
};

Fixture* getFixture() {
  static std::unique_ptr<Fixture> f = [] {
    std::unique_ptr<Fixture> x;
    if (!std::filesystem::exists(kImplant + "femoral_component.stl")) return x;
    x = std::make_unique<Fixture>();
    x->femur = io::readStl(kImplant + "femoral_component.stl", {1.0, true, 0.01, 0.5});
    x->insert = io::readStl(kImplant + "tibial_insert.stl", {1.0, true, 0.01, 0.5});
    const contact::CondyleFits fits = contact::fitCondyles(x->femur, contact::ArticularSelection{});
    const contact::SeatingSetup setup = contact::makeSeatingSetup(x->femur, x->insert, fits.both.cylinder);
    x->points_I = contact::getPositions(setup.insert_medial_I);
    for (const Vector3d& p : contact::getPositions(setup.insert_lateral_I)) x->points_I.push_back(p);
    contact::Seater seater(setup);
    std::vector<double> flexions;
    for (int deg = 0; deg <= 70; ++deg) flexions.push_back(deg * contact::kDegree);
    const auto seats = seater.calcHingeKinematics(flexions);
    for (const auto& s : seats) x->X_FI.push_back(s.X_IF.inverse());
    for (int k = int(seats.size()) - 2; k >= 0; --k) x->X_FI.push_back(seats[size_t(k)].X_IF.inverse());
    x->registry.loadPlugin("distance_fcl");
    std::printf("fixture: %zu insert articular vertices, femoral component %d triangles, %zu frames (0..70..0 deg)\n",
                x->points_I.size(), x->femur.getNumTriangles(), x->X_FI.size());
    return x;
  }();
  return f.get();
}

using StatsFn = int (*)(void*, long long*, int);

// The provider library's diagnostic counters (calls, points, coherent skips, cluster queries,
// clusters culled, point queries, unbounded queries), or nullptr.
StatsFn findStats(const kneesim::plugin::Registry& reg) {
  void* h = dlopen(reg.findOrigin("fcl").c_str(), RTLD_NOW | RTLD_NOLOAD);
  return h ? reinterpret_cast<StatsFn>(dlsym(h, "kneesim_distance_fcl_get_stats")) : nullptr;
}

void BM_DistanceMap(benchmark::State& state, const std::string& provider) {
  Fixture* f = getFixture();
  if (!f) return state.SkipWithError("kgc4-jw implant data not found");
  std::unique_ptr<contact::DistanceField> field;
  std::unique_ptr<contact::MeshDistance> md;
  if (provider == "MeshDistance")
    md = std::make_unique<contact::MeshDistance>(f->femur);
  else
    field = std::make_unique<contact::DistanceField>(f->registry.getDistanceProvider(provider), f->femur, f->points_I);
  std::vector<double> d(f->points_I.size());
  contact::MeshDistanceQuery q;
  size_t frame = 0;
  long long near = 0, frames = 0;
  for (auto _ : state) {
    const Eigen::Isometry3d& X = f->X_FI[frame];
    if (field) {
      field->calcDistances(X, kSearch, d);
    } else {
      for (size_t i = 0; i < d.size(); ++i)
        d[i] = md->calcSignedDistance(X * f->points_I[i], kSearch, q) ? q.distance : HUGE_VAL;
    }
    for (double v : d) near += std::abs(v) <= kSearch;
    ++frames;
    frame = (frame + 1) % f->X_FI.size();
  }
  state.SetItemsProcessed(int64_t(state.iterations()) * int64_t(f->points_I.size()));
  state.counters["near"] = double(near) / double(std::max(1LL, frames));
  if (field && provider != "MeshDistance") {
    if (StatsFn stats = findStats(f->registry)) {
      long long s[7] = {};
      stats(field->getProviderContext(), s, 7);
      const double calls = double(std::max(1LL, s[0]));
      state.counters["queries"] = double(s[3] + s[5] + s[6]) / calls;
      state.counters["skips"] = double(s[2]) / calls;
      state.counters["cluster_q"] = double(s[3]) / calls;
      state.counters["culled"] = double(s[4]) / calls;
      state.counters["point_q"] = double(s[5]) / calls;
      state.counters["unbounded_q"] = double(s[6]) / calls;
    }
  }
}
BENCHMARK_CAPTURE(BM_DistanceMap, fcl, std::string("fcl"))->Unit(benchmark::kMillisecond);
BENCHMARK_CAPTURE(BM_DistanceMap, fcl_pruned, std::string("fcl_pruned"))->Unit(benchmark::kMillisecond);
BENCHMARK_CAPTURE(BM_DistanceMap, fcl_naive, std::string("fcl_naive"))->Unit(benchmark::kMillisecond);
BENCHMARK_CAPTURE(BM_DistanceMap, MeshDistance, std::string("MeshDistance"))->Unit(benchmark::kMillisecond);

// Both FCL maps over the same frames in the same run.
void BM_FclVsNaiveSameFrames(benchmark::State& state) {
  Fixture* f = getFixture();
  if (!f) return state.SkipWithError("kgc4-jw implant data not found");
  using Clock = std::chrono::steady_clock;
  double fast_s = 0, naive_s = 0, max_diff = 0;
  long long frames = 0;
  for (auto _ : state) {
    contact::DistanceField fast(f->registry.getDistanceProvider("fcl"), f->femur, f->points_I);
    contact::DistanceField naive(f->registry.getDistanceProvider("fcl_naive"), f->femur, f->points_I);
    std::vector<double> a(f->points_I.size()), b(f->points_I.size());
    for (const Eigen::Isometry3d& X : f->X_FI) {
      const auto t0 = Clock::now();
      fast.calcDistances(X, kSearch, a);
      const auto t1 = Clock::now();
      naive.calcDistances(X, kSearch, b);
      const auto t2 = Clock::now();
      fast_s += std::chrono::duration<double>(t1 - t0).count();
      naive_s += std::chrono::duration<double>(t2 - t1).count();
      for (size_t i = 0; i < a.size(); ++i)
        if (std::abs(b[i]) <= kSearch) max_diff = std::max(max_diff, std::abs(a[i] - b[i]));
      ++frames;
    }
  }
  state.counters["fcl_ms_per_frame"] = 1e3 * fast_s / double(frames);
  state.counters["naive_ms_per_frame"] = 1e3 * naive_s / double(frames);
  state.counters["speedup"] = naive_s / fast_s;
  state.counters["max_diff_m"] = max_diff;
}
BENCHMARK(BM_FclVsNaiveSameFrames)->Unit(benchmark::kMillisecond)->Iterations(1);

// The whole per-frame contact area (distance map at the search radius, partial-triangle areas at
// the threshold and 4 extra thresholds, compartments and centroids), "fcl" provider.
void BM_ContactAreaFrame(benchmark::State& state) {
  Fixture* f = getFixture();
  if (!f) return state.SkipWithError("kgc4-jw implant data not found");
  contact::ContactAreaOptions o;
  o.extra_thresholds = {2e-3, 3e-3, 5e-3, 6e-3};
  const contact::ContactAreaCalculator calc(f->insert, f->femur, o, &f->registry.getDistanceProvider("fcl"));
  auto ws = calc.createWorkspace();
  contact::ContactFrame out;
  size_t frame = 0;
  double S = 0;
  for (auto _ : state) {
    calc.calcFrame(*ws, f->X_FI[frame].inverse(), out);
    S += out.S;
    frame = (frame + 1) % f->X_FI.size();
  }
  state.counters["search_mm"] = calc.getSearchRadius() * 1e3;
  state.counters["mean_S_mm2"] = S / double(state.iterations()) * 1e6;
}
BENCHMARK(BM_ContactAreaFrame)->Unit(benchmark::kMillisecond);

}  // namespace

BENCHMARK_MAIN();
