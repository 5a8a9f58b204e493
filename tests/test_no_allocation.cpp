// Proof that the solver never touches the heap after construction: global operator new/delete and
// malloc-through-Eigen are counted while a whole manhattanOlson3500 run goes through it (a
// synthetic world of the same size when the dataset is absent).
#define EIGEN_RUNTIME_NO_MALLOC
#include <doctest/doctest.h>

#include <atomic>
#include <cstdio>
#include <cstdlib>
#include <fstream>
#include <memory>
#include <new>
#include <vector>

#include "host_sim/dataset_io.h"
#include "host_sim/incremental_run.h"
#include "host_sim/steps.h"
#include "host_sim/synthetic.h"

namespace {
std::atomic<bool> g_counting{false};
std::atomic<long> g_allocations{0};

void* countedAlloc(std::size_t size) {
  if (g_counting.load()) ++g_allocations;
  if (void* p = std::malloc(size == 0 ? 1 : size)) return p;
  throw std::bad_alloc();
}

void* countedAlignedAlloc(std::size_t size, std::align_val_t alignment) {
  if (g_counting.load()) ++g_allocations;
  const std::size_t align = static_cast<std::size_t>(alignment);
  // aligned_alloc wants a size that is a multiple of the alignment.
  const std::size_t rounded = ((size == 0 ? 1 : size) + align - 1) / align * align;
  if (void* p = std::aligned_alloc(align, rounded)) return p;
  throw std::bad_alloc();
}

void countedFree(void* p) noexcept {
  if (g_counting.load() && p != nullptr) ++g_allocations;
  std::free(p);
}
}  // namespace

// Every replaceable form, aligned ones included, so that no allocation can slip past the count.
void* operator new(std::size_t size) {
  return countedAlloc(size);
}
void* operator new[](std::size_t size) {
  return countedAlloc(size);
}
void* operator new(std::size_t size, std::align_val_t alignment) {
  return countedAlignedAlloc(size, alignment);
}
void* operator new[](std::size_t size, std::align_val_t alignment) {
  return countedAlignedAlloc(size, alignment);
}
void operator delete(void* p) noexcept {
  countedFree(p);
}
void operator delete[](void* p) noexcept {
  countedFree(p);
}
void operator delete(void* p, std::size_t) noexcept {
  countedFree(p);
}
void operator delete[](void* p, std::size_t) noexcept {
  countedFree(p);
}
void operator delete(void* p, std::align_val_t) noexcept {
  countedFree(p);
}
void operator delete[](void* p, std::align_val_t) noexcept {
  countedFree(p);
}
void operator delete(void* p, std::size_t, std::align_val_t) noexcept {
  countedFree(p);
}
void operator delete[](void* p, std::size_t, std::align_val_t) noexcept {
  countedFree(p);
}

using namespace lslam;
using namespace lslam::sim;

TEST_CASE("no heap allocation from the first step to the last of a whole run") {
  const std::string path = std::string(LSLAM_DATASETS_DIR) + "/2d/manhattanOlson3500.g2o";
  Dataset2D d;
  if (std::ifstream(path).good()) {
    d = readDataset2D(path);
  } else {
    MESSAGE("SKIP real data: " << path << " not found; using a synthetic world of 3500 poses");
    SyntheticOptions o;
    o.poses = 3500;
    d = generateManhattanWorld(o).dataset;
  }
  // Every input is prepared before counting starts: the robot holds them in its own buffers.
  // Initial values come from the file (vertices, or zero): the point here is memory, not accuracy.
  const std::vector<Step> steps = buildSteps(d, StepOrder::Online);
  const Estimate2D vertices = estimateFromVertices(d);
  std::vector<PoseInput> poses(steps.size());
  std::vector<std::vector<FactorInput>> factors(steps.size());
  for (std::size_t s = 0; s < steps.size(); ++s) {
    poses[s].id = steps[s].new_pose;
    if (auto it = vertices.find(steps[s].new_pose); it != vertices.end())
      poses[s].initial = SE2(it->second.x, it->second.y, it->second.theta);
    for (std::size_t e : steps[s].edges) factors[s].push_back(toFactorInput(d.edges[e]));
  }
  auto solver = std::make_unique<HostSolver2D>();

  Status worst = Status::Ok;
  g_allocations = 0;
  Eigen::internal::set_is_malloc_allowed(false);
  g_counting = true;
  for (std::size_t s = 0; s < steps.size(); ++s) {
    const Status status =
        solver->update(&poses[s], 1, factors[s].data(), static_cast<Index>(factors[s].size()));
    if (status != Status::Ok) worst = status;
  }
  const Status optimized = solver->optimize(5, 1e-9);
  g_counting = false;
  Eigen::internal::set_is_malloc_allowed(true);

  CHECK(worst == Status::Ok);
  CHECK(optimized == Status::Ok);
  CHECK(solver->poses() == static_cast<Index>(steps.size()));
  CHECK(g_allocations.load() == 0);
  // The counter itself works: an allocation while counting is seen.
  g_counting = true;
  auto probe = std::make_unique<int>(1);
  g_counting = false;
  CHECK(g_allocations.load() == 1);
}
