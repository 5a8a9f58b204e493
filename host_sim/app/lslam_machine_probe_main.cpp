// lslam-machine-probe: how fast this machine is right now, printed next to benchmark figures.
//
// The machines these benchmarks run on are shared: the same binary on the same data can take up to
// twice its quiet time from one hour to the next. This probe measures the two things the solver's
// time follows, so that a table can be read against the state of the machine it was taken in:
//   - the CPU: a fixed chain of 2.5e8 dependent multiply-adds in a register (one multiply's and
//     one add's latency each, whatever the memory does);
//   - the memory: a random pointer chase over 1 MB and 16 MB (the latency of a cache the factor of
//     a 3,500-pose graph fits in, and of main memory), and a sequential read of 64 MB (the
//     bandwidth; a 10,000-pose factor is ~10 MB).
// It prints numbers, never a verdict; nothing is scaled by them.
#include <chrono>
#include <cstdint>
#include <cstdio>
#include <numeric>
#include <vector>

namespace {

double seconds(std::chrono::steady_clock::time_point a, std::chrono::steady_clock::time_point b) {
  return std::chrono::duration<double>(b - a).count();
}

double spinSeconds() {
  const auto start = std::chrono::steady_clock::now();
  std::uint64_t x = 1;
  for (std::uint64_t i = 0; i < 250000000ULL; ++i) x = x * 6364136223846793005ULL + i;
  const double t = seconds(start, std::chrono::steady_clock::now());
  volatile std::uint64_t sink = x;
  (void)sink;
  return t;
}

// A single random cycle through `bytes` of pointers (Sattolo's shuffle), so every load depends on
// the one before and the prefetchers cannot guess the next address. Nanoseconds per load.
double chaseNanoseconds(std::size_t bytes) {
  const std::size_t n = bytes / sizeof(std::size_t);
  std::vector<std::size_t> next(n);
  std::iota(next.begin(), next.end(), std::size_t{0});
  std::uint64_t state = 12345;
  for (std::size_t i = n - 1; i > 0; --i) {
    state = state * 6364136223846793005ULL + 1442695040888963407ULL;
    std::swap(next[i], next[(state >> 17) % i]);
  }
  std::size_t p = 0;
  for (std::size_t i = 0; i < n; ++i) p = next[p];  // warm up: every line once
  const std::size_t loads = 4000000;
  const auto start = std::chrono::steady_clock::now();
  for (std::size_t i = 0; i < loads; ++i) p = next[p];
  const double t = seconds(start, std::chrono::steady_clock::now());
  volatile std::size_t sink = p;
  (void)sink;
  return t / static_cast<double>(loads) * 1e9;
}

// Integer sums, which the compiler vectorizes with no dependency chain longer than an add, so the
// loop runs at the memory's pace rather than at a floating-point add's latency.
double readGigabytesPerSecond(std::size_t bytes) {
  std::vector<std::uint64_t> data(bytes / sizeof(std::uint64_t), 1);
  std::uint64_t sum = 0;
  const int passes = 8;
  const auto start = std::chrono::steady_clock::now();
  for (int r = 0; r < passes; ++r)
    sum += std::accumulate(data.begin(), data.end(), std::uint64_t{0});
  const double t = seconds(start, std::chrono::steady_clock::now());
  volatile std::uint64_t sink = sum;
  (void)sink;
  return static_cast<double>(bytes) * passes / t / 1e9;
}

}  // namespace

int main() {
  const double spin = spinSeconds();
  const double chase_1mb = chaseNanoseconds(std::size_t{1} << 20);
  const double chase_16mb = chaseNanoseconds(std::size_t{16} << 20);
  const double read = readGigabytesPerSecond(std::size_t{64} << 20);
  std::printf(
      "machine: spin %.3f s (2.5e8 dependent multiply-adds), pointer chase %.1f ns (1 MB) / %.1f "
      "ns (16 MB), "
      "sequential read %.1f GB/s\n",
      spin, chase_1mb, chase_16mb, read);
  return 0;
}
