// Implant geometry speed on JW's components (data/kgc4-jw): exact signed-distance queries
// near the insert, the condyle cylinder fits (point selection included), and seating the femoral
// component, cold (neutral, from the default start) and warm (each degree of a flexion series
// started from the previous one, as calcHingeKinematics does).
#include <benchmark/benchmark.h>

#include <filesystem>
#include <memory>

#include "contact/condyle.hpp"
#include "contact/mesh_distance.hpp"
#include "contact/seating.hpp"

namespace {

namespace contact = kneesim::contact;
namespace io = kneesim::io;

const std::string kImplant = std::string(KNEESIM_DATA_DIR) + "/kgc4-jw/implant/";

bool haveData(benchmark::State& state) {
  if (std::filesystem::exists(kImplant + "femoral_component.stl")) return true;
  state.SkipWithError("kgc4-jw implant data not found");
  return false;
}

io::TriangleMesh readMesh(const std::string& name) { return io::readStl(kImplant + name, {1.0, true, 0.01, 0.5}); }

// Points 0..2 mm above and below the insert's upward-facing vertices: the queries seating makes.
void BM_MeshDistanceNearInsert(benchmark::State& state) {
  if (!haveData(state)) return;
  const io::TriangleMesh insert = readMesh("tibial_insert.stl");
  const contact::MeshDistance md(insert);
  const auto normals = insert.calcVertexNormals();
  std::vector<Eigen::Vector3d> pts;
  for (int v = 0; v < insert.getNumVertices(); ++v)
    if (normals[v].y() > 0.5) pts.push_back(insert.vertices[v] + (pts.size() % 5 - 2) * 0.5e-3 * normals[v]);
  contact::MeshDistanceQuery q;
  double sum = 0;
  for (auto _ : state) {
    for (const auto& p : pts) sum += md.calcSignedDistance(p, 3e-3, q) ? q.distance : 0;
    benchmark::DoNotOptimize(sum);
  }
  state.SetItemsProcessed(int64_t(state.iterations()) * int64_t(pts.size()));
}
BENCHMARK(BM_MeshDistanceNearInsert)->Unit(benchmark::kMicrosecond);

void BM_FitCondylesJw(benchmark::State& state) {
  if (!haveData(state)) return;
  const io::TriangleMesh femur = readMesh("femoral_component.stl");
  for (auto _ : state) benchmark::DoNotOptimize(contact::fitCondyles(femur, contact::ArticularSelection{}));
}
BENCHMARK(BM_FitCondylesJw)->Unit(benchmark::kMillisecond);

std::unique_ptr<contact::Seater> makeJwSeater() {
  io::TriangleMesh femur = readMesh("femoral_component.stl");
  const contact::CondyleFits fits = contact::fitCondyles(femur, contact::ArticularSelection{});
  return std::make_unique<contact::Seater>(
      contact::makeSeatingSetup(std::move(femur), readMesh("tibial_insert.stl"), fits.both.cylinder));
}

void BM_SeatingNeutralJw(benchmark::State& state) {
  if (!haveData(state)) return;
  auto seater = makeJwSeater();
  contact::SeatingResult r;
  for (auto _ : state) r = seater->calcNeutralSeating();
  state.counters["distance_evaluations"] = r.distance_evaluations;
  state.counters["gap_um"] = 1e6 * std::max(std::abs(r.gap_medial), std::abs(r.gap_lateral));
}
BENCHMARK(BM_SeatingNeutralJw)->Unit(benchmark::kMillisecond);

void BM_SeatingWarmPerDegreeJw(benchmark::State& state) {
  if (!haveData(state)) return;
  auto seater = makeJwSeater();
  contact::SeatingResult r = seater->calcSeating(0.0);
  int deg = 0, evaluations = 0, seats = 0;
  for (auto _ : state) {
    deg = deg % 120 + 1;
    r = seater->calcSeating(deg * contact::kDegree, &r.q);
    evaluations += r.distance_evaluations;
    ++seats;
  }
  state.counters["distance_evaluations"] = double(evaluations) / std::max(1, seats);
}
BENCHMARK(BM_SeatingWarmPerDegreeJw)->Unit(benchmark::kMillisecond);

}  // namespace

BENCHMARK_MAIN();
