// Proof that the solver never touches the heap after construction: every heap call of the process
// is counted while a whole manhattanOlson3500 run goes through it (a synthetic world of the same
// size when the dataset is absent), from the first update to the last and the final optimize().
//
// The counting sits at the allocator, not in the code that calls it. This executable defines the C
// allocator's entry points (malloc, calloc, realloc, reallocarray, free, aligned_alloc,
// posix_memalign, memalign, valloc, pvalloc) and forwards them to glibc's own (__libc_malloc and
// the rest): a definition in the executable takes the place of libc's for the whole process, so
// the solver's library, Eigen's aligned_malloc (which calls std::malloc), libstdc++, libc's
// internal calls and every shared library go through them. It also replaces every form of global
// operator new and delete (sized, aligned, nothrow, array), which forward to glibc directly and are
// counted apart. Controls show that each entry point, and a vector, an Eigen matrix and a raw
// malloc while counting, are seen, so a run that counts nothing is not a counter that sees nothing.
//
// Debian 12 (glibc 2.36) x86-64.
#include <doctest/doctest.h>
#include <malloc.h>

#include <Eigen/Core>
#include <atomic>
#include <cerrno>
#include <cstddef>
#include <cstdint>
#include <cstdlib>
#include <fstream>
#include <memory>
#include <new>
#include <string>
#include <vector>

#include "host_sim/dataset_io.h"
#include "host_sim/incremental_run.h"
#include "host_sim/steps.h"
#include "host_sim/synthetic.h"

// glibc's allocator under its own names (exported for exactly this use).
extern "C" {
void* __libc_malloc(std::size_t size) noexcept;
void* __libc_calloc(std::size_t count, std::size_t size) noexcept;
void* __libc_realloc(void* p, std::size_t size) noexcept;
void __libc_free(void* p) noexcept;
void* __libc_memalign(std::size_t alignment, std::size_t size) noexcept;
void* __libc_valloc(std::size_t size) noexcept;
void* __libc_pvalloc(std::size_t size) noexcept;
}

namespace {

// Lock-free atomics with constant initialization: valid before any constructor runs (the loader
// and libc allocate early), and the hooks never allocate or lock.
static_assert(std::atomic<bool>::is_always_lock_free && std::atomic<long>::is_always_lock_free);
std::atomic<bool> g_counting{false};
std::atomic<long> g_c_allocations{0};  // every C allocator call but free
std::atomic<long> g_c_frees{0};        // free of a non-null pointer
std::atomic<long> g_news{0};           // every form of operator new
std::atomic<long> g_deletes{0};        // every form of operator delete, of a non-null pointer

void note(std::atomic<long>& counter) noexcept {
  if (g_counting.load()) counter.fetch_add(1);
}

bool powerOfTwo(std::size_t x) {
  return x != 0 && (x & (x - 1)) == 0;
}

}  // namespace

extern "C" {

void* malloc(std::size_t size) noexcept {
  note(g_c_allocations);
  return __libc_malloc(size);
}

void* calloc(std::size_t count, std::size_t size) noexcept {
  note(g_c_allocations);
  return __libc_calloc(count, size);
}

void* realloc(void* p, std::size_t size) noexcept {
  note(g_c_allocations);
  return __libc_realloc(p, size);
}

void* reallocarray(void* p, std::size_t count, std::size_t size) noexcept {
  note(g_c_allocations);
  if (size != 0 && count > SIZE_MAX / size) {
    errno = ENOMEM;
    return nullptr;
  }
  return __libc_realloc(p, count * size);
}

void free(void* p) noexcept {
  if (p != nullptr) note(g_c_frees);
  __libc_free(p);
}

void* memalign(std::size_t alignment, std::size_t size) noexcept {
  note(g_c_allocations);
  return __libc_memalign(alignment, size);
}

void* aligned_alloc(std::size_t alignment, std::size_t size) noexcept {
  note(g_c_allocations);
  if (!powerOfTwo(alignment)) {
    errno = EINVAL;
    return nullptr;
  }
  return __libc_memalign(alignment, size);
}

int posix_memalign(void** out, std::size_t alignment, std::size_t size) noexcept {
  note(g_c_allocations);
  if (!powerOfTwo(alignment) || alignment % sizeof(void*) != 0) return EINVAL;
  void* p = __libc_memalign(alignment, size);
  if (p == nullptr) return ENOMEM;
  *out = p;
  return 0;
}

void* valloc(std::size_t size) noexcept {
  note(g_c_allocations);
  return __libc_valloc(size);
}

void* pvalloc(std::size_t size) noexcept {
  note(g_c_allocations);
  return __libc_pvalloc(size);
}

}  // extern "C"

namespace {

// operator new's contract: retry through the new-handler, throw std::bad_alloc without one.
template <class Allocate>
void* newOrThrow(Allocate allocate) {
  note(g_news);
  for (;;) {
    if (void* p = allocate()) return p;
    const std::new_handler handler = std::get_new_handler();
    if (handler == nullptr) throw std::bad_alloc();
    handler();
  }
}

void* newUnaligned(std::size_t size) {
  return newOrThrow([size] { return __libc_malloc(size == 0 ? 1 : size); });
}

void* newAligned(std::size_t size, std::align_val_t alignment) {
  return newOrThrow([size, alignment] {
    return __libc_memalign(static_cast<std::size_t>(alignment), size == 0 ? 1 : size);
  });
}

void deleteAny(void* p) noexcept {
  if (p == nullptr) return;
  note(g_deletes);
  __libc_free(p);
}

}  // namespace

// Every replaceable form: the plain and aligned ones allocate; array and nothrow forms do what
// the default ones do, the plain form of the same alignment, and are counted there.
void* operator new(std::size_t size) {
  return newUnaligned(size);
}
void* operator new[](std::size_t size) {
  return newUnaligned(size);
}
void* operator new(std::size_t size, std::align_val_t alignment) {
  return newAligned(size, alignment);
}
void* operator new[](std::size_t size, std::align_val_t alignment) {
  return newAligned(size, alignment);
}
void* operator new(std::size_t size, const std::nothrow_t&) noexcept {
  try {
    return newUnaligned(size);
  } catch (...) {
    return nullptr;
  }
}
void* operator new[](std::size_t size, const std::nothrow_t&) noexcept {
  try {
    return newUnaligned(size);
  } catch (...) {
    return nullptr;
  }
}
void* operator new(std::size_t size, std::align_val_t alignment, const std::nothrow_t&) noexcept {
  try {
    return newAligned(size, alignment);
  } catch (...) {
    return nullptr;
  }
}
void* operator new[](std::size_t size, std::align_val_t alignment, const std::nothrow_t&) noexcept {
  try {
    return newAligned(size, alignment);
  } catch (...) {
    return nullptr;
  }
}
void operator delete(void* p) noexcept {
  deleteAny(p);
}
void operator delete[](void* p) noexcept {
  deleteAny(p);
}
void operator delete(void* p, std::size_t) noexcept {
  deleteAny(p);
}
void operator delete[](void* p, std::size_t) noexcept {
  deleteAny(p);
}
void operator delete(void* p, std::align_val_t) noexcept {
  deleteAny(p);
}
void operator delete[](void* p, std::align_val_t) noexcept {
  deleteAny(p);
}
void operator delete(void* p, std::size_t, std::align_val_t) noexcept {
  deleteAny(p);
}
void operator delete[](void* p, std::size_t, std::align_val_t) noexcept {
  deleteAny(p);
}
void operator delete(void* p, const std::nothrow_t&) noexcept {
  deleteAny(p);
}
void operator delete[](void* p, const std::nothrow_t&) noexcept {
  deleteAny(p);
}
void operator delete(void* p, std::align_val_t, const std::nothrow_t&) noexcept {
  deleteAny(p);
}
void operator delete[](void* p, std::align_val_t, const std::nothrow_t&) noexcept {
  deleteAny(p);
}

namespace {

// The heap calls counted while one span ran.
struct HeapCalls {
  long c_allocations = 0;
  long c_frees = 0;
  long news = 0;
  long deletes = 0;
  long total() const { return c_allocations + c_frees + news + deletes; }
};

// Runs span() with counting on, and only it.
template <class Span>
HeapCalls countHeapCalls(Span span) {
  g_c_allocations = 0;
  g_c_frees = 0;
  g_news = 0;
  g_deletes = 0;
  g_counting = true;
  span();
  g_counting = false;
  return HeapCalls{g_c_allocations.load(), g_c_frees.load(), g_news.load(), g_deletes.load()};
}

// Where the controls' pointers go, so that the compiler cannot drop an allocation whose pointer
// nobody reads.
void* volatile g_sink = nullptr;

}  // namespace

using namespace lslam;
using namespace lslam::sim;

TEST_CASE("every heap entry point of the process is counted while counting, and only then") {
  // The C allocator, each call once.
  const HeapCalls c = countHeapCalls([] {
    void* p = std::malloc(24);
    g_sink = p;
    p = std::realloc(p, 4096);
    g_sink = p;
    std::free(p);
    p = std::calloc(3, 8);
    g_sink = p;
    std::free(p);
    p = reallocarray(nullptr, 5, 8);
    g_sink = p;
    std::free(p);
    p = std::aligned_alloc(64, 128);
    g_sink = p;
    std::free(p);
    p = nullptr;
    if (posix_memalign(&p, 64, 100) == 0) g_sink = p;
    std::free(p);
    p = memalign(32, 40);
    g_sink = p;
    std::free(p);
    p = valloc(10);
    g_sink = p;
    std::free(p);
    p = pvalloc(10);
    g_sink = p;
    std::free(p);
    std::free(nullptr);  // not a release: nothing was allocated
  });
  CHECK(c.c_allocations == 9);
  CHECK(c.c_frees == 8);
  CHECK(c.news == 0);
  CHECK(c.deletes == 0);
  // operator new and delete, each form once (delete of null is no call to the heap).
  struct alignas(64) Wide {
    double x[8];
  };
  const HeapCalls cpp = countHeapCalls([] {
    int* i = new int(1);
    g_sink = i;
    delete i;
    int* a = new int[3];
    g_sink = a;
    delete[] a;
    Wide* w = new Wide();
    g_sink = w;
    delete w;
    Wide* wa = new Wide[2];
    g_sink = wa;
    delete[] wa;
    int* n = new (std::nothrow) int(2);
    g_sink = n;
    delete n;
    int* na = new (std::nothrow) int[2];
    g_sink = na;
    delete[] na;
    Wide* nw = new (std::nothrow) Wide();
    g_sink = nw;
    delete nw;
    Wide* nwa = new (std::nothrow) Wide[2];
    g_sink = nwa;
    delete[] nwa;
    // The forms a delete-expression does not call here: direct calls.
    void* p = ::operator new(16);
    ::operator delete (p, std::size_t{16});
    p = ::operator new[](16);
    ::operator delete[](p, std::size_t{16});
    p = ::operator new (64, std::align_val_t{64});
    ::operator delete (p, std::align_val_t{64});
    p = ::operator new[](64, std::align_val_t{64});
    ::operator delete[](p, std::align_val_t{64});
    p = ::operator new (64, std::align_val_t{64});
    ::operator delete (p, std::size_t{64}, std::align_val_t{64});
    p = ::operator new[](64, std::align_val_t{64});
    ::operator delete[](p, std::size_t{64}, std::align_val_t{64});
    p = ::operator new(8, std::nothrow);
    ::operator delete(p, std::nothrow);
    p = ::operator new[](8, std::nothrow);
    ::operator delete[](p, std::nothrow);
    p = ::operator new (64, std::align_val_t{64}, std::nothrow);
    ::operator delete (p, std::align_val_t{64}, std::nothrow);
    p = ::operator new[](64, std::align_val_t{64}, std::nothrow);
    ::operator delete[](p, std::align_val_t{64}, std::nothrow);
    delete static_cast<int*>(nullptr);
  });
  CHECK(cpp.news == 18);
  CHECK(cpp.deletes == 18);
  CHECK(cpp.c_allocations == 0);
  CHECK(cpp.c_frees == 0);
  // Nothing is counted while counting is off.
  void* p = std::malloc(8);
  g_sink = p;
  std::free(p);
  CHECK(HeapCalls{g_c_allocations.load(), g_c_frees.load(), g_news.load(), g_deletes.load()}
            .total() == cpp.total());
}

TEST_CASE("no heap allocation from the first step to the last of a whole run") {
  // Reading and preparing the input is counted too: allocations in the host library's code (not
  // this file's) must be seen, or the run's zero below would prove nothing about the solver's.
  const std::string path = std::string(LSLAM_DATASETS_DIR) + "/2d/manhattanOlson3500.g2o";
  Dataset2D d;
  const HeapCalls reading = countHeapCalls([&] {
    if (std::ifstream(path).good()) {
      d = readDataset2D(path);
    } else {
      MESSAGE("SKIP real data: " << path << " not found; using a synthetic world of 3500 poses");
      SyntheticOptions o;
      o.poses = 3500;
      d = generateManhattanWorld(o).dataset;
    }
  });
  CHECK(reading.news > 0);
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
  Status optimized = Status::Ok;
  const HeapCalls run = countHeapCalls([&] {
    for (std::size_t s = 0; s < steps.size(); ++s) {
      const Status status =
          solver->update(&poses[s], 1, factors[s].data(), static_cast<Index>(factors[s].size()));
      if (status != Status::Ok) worst = status;
    }
    optimized = solver->optimize(5, 1e-9);
  });

  CHECK(worst == Status::Ok);
  CHECK(optimized == Status::Ok);
  CHECK(solver->poses() == static_cast<Index>(steps.size()));
  MESSAGE("heap calls over " << steps.size() << " updates and optimize(): " << run.c_allocations
                             << " C allocations, " << run.c_frees << " frees, " << run.news
                             << " new, " << run.deletes << " delete (reading the input: "
                             << reading.c_allocations << ", " << reading.c_frees << ", "
                             << reading.news << ", " << reading.deletes << ")");
  CHECK(run.c_allocations == 0);
  CHECK(run.c_frees == 0);
  CHECK(run.news == 0);
  CHECK(run.deletes == 0);

  // The counter sees what it must in the same span: a vector's growth (operator new), a dynamic
  // Eigen matrix (Eigen's aligned_malloc, std::malloc) and a raw std::malloc, each with its
  // release.
  const HeapCalls vector = countHeapCalls([] {
    std::vector<int> v;
    v.push_back(1);
    g_sink = v.data();
  });
  CHECK(vector.news == 1);
  CHECK(vector.deletes == 1);
  CHECK(vector.c_allocations == 0);
  const HeapCalls matrix = countHeapCalls([] {
    Eigen::MatrixXd m(8, 8);
    m.setZero();
    g_sink = m.data();
  });
  CHECK(matrix.c_allocations == 1);
  CHECK(matrix.c_frees == 1);
  CHECK(matrix.news == 0);
  const HeapCalls raw = countHeapCalls([] {
    void* p = std::malloc(32);
    g_sink = p;
    std::free(p);
  });
  CHECK(raw.c_allocations == 1);
  CHECK(raw.c_frees == 1);
  CHECK(raw.news == 0);
}
