// A rig build under a ThreadBudget (facecast/core/threads.hpp; its loops are tested in tests/core):
// OpenMP regions get one thread unless lent more, the work a build starts beside its own thread
// runs on a lent thread or later on its own, and a rig build keeps to that.
#include <dlfcn.h>
#include <dlib/matrix.h>
#include <omp.h>

#include <algorithm>
#include <catch2/catch.hpp>
#include <random>
#include <thread>
#include <tuple>

#include "facecast/core/threads.hpp"
#include "facecast/rig/rig.hpp"
#include "facecast/rigbuild/build.hpp"
#include "parallel.hpp"

using namespace facecast;
using namespace facecast::rigbuild;

namespace {

// A flat n x n grid and a shape that lifts one corner: a rig build with little work.
rig::Rig lifted_grid(int n) {
  rig::Rig r;
  r.positions.resize(n * n, 3);
  for (int y = 0; y < n; ++y)
    for (int x = 0; x < n; ++x) r.positions.row(y * n + x) << float(x), float(y), 0.0f;
  r.triangles.resize(2 * (n - 1) * (n - 1), 3);
  int t = 0;
  for (int y = 0; y + 1 < n; ++y) {
    for (int x = 0; x + 1 < n; ++x) {
      const int a = y * n + x;
      r.triangles.row(t++) << a, a + 1, a + n + 1;
      r.triangles.row(t++) << a, a + n + 1, a + n;
    }
  }
  r.triangle_material.assign(static_cast<std::size_t>(t), 0);
  r.materials.push_back(rig::Material::solid("skin", {1, 1, 1, 1}));
  r.normals = rig::vertex_normals(r.positions, r.triangles);
  rig::Positions d = rig::Positions::Zero(n * n, 3);
  d(n * n - 1, 2) = 0.3f;
  r.shapes.push_back(rig::Blendshape::from_dense("corner", d));
  return r;
}

// The most OpenMP threads that the calling thread's regions could get at any progress report of
// a rig build made here (reports from the build's workers are not this thread's setting).
int openmp_threads_during_build() {
  const rig::Rig tmpl = lifted_grid(8);
  rig::Rig target = tmpl;
  target.shapes.clear();
  target.positions *= 1.3f;
  BuildOptions opt;
  opt.virtual_edges = VirtualEdgeMode::kOff;
  const auto caller = std::this_thread::get_id();
  int most = 0;
  const auto r = build_rig(tmpl, target, opt, [&](std::string_view, double) {
    if (std::this_thread::get_id() == caller) most = std::max(most, omp_get_max_threads());
  });
  CHECK(r.rig.shapes.size() == 1);
  return most;
}

}  // namespace

TEST_CASE("OpenMP regions started under a budget get what it can lend", "[threads]") {
  ThreadBudget budget(2);
  const ThreadBudgetScope scope(budget);
  const OpenMpWithinBudget operation;  // as build_rig opens one
  CHECK(omp_get_max_threads() == 1);
  int team = 0;
  {
    const OpenMpThreads lend;
    CHECK(omp_get_max_threads() <= 2);
#pragma omp parallel
    {
#pragma omp single
      team = omp_get_num_threads();
    }
  }
  CHECK(team >= 1);
  CHECK(team <= 2);
  CHECK(budget.available() == 1);  // the lent thread is back; the scope holds one
}

TEST_CASE("a rig build under a budget runs its OpenMP regions on its own thread", "[threads]") {
  const int before = omp_get_max_threads();
  omp_set_num_threads(3);  // this thread's setting, whatever the machine's cores
  SECTION("under a budget") {
    ThreadBudget budget(2);
    const ThreadBudgetScope scope(budget);
    CHECK(openmp_threads_during_build() == 1);
    CHECK(omp_get_max_threads() == 3);  // given back
    CHECK(budget.available() == 1);
  }
  SECTION("without one") {
    CHECK(openmp_threads_during_build() == 3);
    CHECK(omp_get_max_threads() == 3);
  }
  omp_set_num_threads(before);
}

TEST_CASE("work started beside a build's own stays within its budget", "[threads]") {
  const auto caller = std::this_thread::get_id();
  SECTION("a budget with a thread to lend: the work runs on another thread that holds it") {
    ThreadBudget budget(2);
    const ThreadBudgetScope scope(budget);
    auto work = async_within_budget([&] {
      return std::make_tuple(std::this_thread::get_id(), current_thread_budget(),
                             budget.available());
    });
    const auto [where, under, left] = work.get();
    CHECK(where != caller);
    CHECK(under == &budget);
    CHECK(left == 0);
    CHECK(budget.available() == 1);  // given back when it ended
  }
  SECTION("a budget with none free: the work runs on the caller when its result is asked for") {
    ThreadBudget budget(1);
    const ThreadBudgetScope scope(budget);
    bool ran = false;
    auto work = async_within_budget([&] {
      ran = true;
      return std::this_thread::get_id();
    });
    CHECK_FALSE(ran);
    CHECK(work.get() == caller);
    CHECK(budget.available() == 0);  // the caller's own
  }
  SECTION("no budget: another thread, as std::async") {
    auto work = async_within_budget([] { return std::this_thread::get_id(); });
    CHECK(work.get() != caller);
  }
}

TEST_CASE("BLAS products made on several threads at once equal the ones made alone", "[threads]") {
  // dlib's shape predictor (photo landmarks, read on the loops' workers) and CHOLMOD multiply
  // through the system's BLAS from several threads at once. Debian's serial OpenBLAS shares its
  // work buffers between callers without a lock: two fits of one photo in one process came out
  // different. install-deps.sh chooses the pthread build, which rigbuild runs on the caller's
  // thread (parallel.cpp).
  std::mt19937 rng(7);
  std::uniform_int_distribution<long> size(2, 48);
  std::uniform_real_distribution<double> value(-1, 1);
  struct Product {
    dlib::matrix<double> a, b, alone;
  };
  std::vector<Product> products(400);
  for (auto& p : products) {
    const long m = size(rng), k = size(rng), n = size(rng);
    p.a.set_size(m, k);
    p.b.set_size(k, n);
    for (auto& x : p.a) x = value(rng);
    for (auto& x : p.b) x = value(rng);
    p.alone = p.a * p.b;  // dlib's BLAS binding: dgemm
  }
  std::vector<int> differing(2, 0);
  std::vector<std::thread> threads;
  for (std::size_t t = 0; t < differing.size(); ++t) {
    threads.emplace_back([&, t] {
      for (int round = 0; round < 20; ++round)
        for (const auto& p : products) {
          const dlib::matrix<double> c = p.a * p.b;
          if (c != p.alone) ++differing[t];
        }
    });
  }
  for (auto& t : threads) t.join();
  CHECK(differing[0] == 0);
  CHECK(differing[1] == 0);
  // ... and OpenBLAS runs on the caller's thread, as the thread budget counts it.
  using GetThreads = int (*)();
  if (void* get = dlsym(RTLD_DEFAULT, "openblas_get_num_threads"))
    CHECK(reinterpret_cast<GetThreads>(get)() == 1);
}
