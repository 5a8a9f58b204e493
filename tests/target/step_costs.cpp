#include "step_costs.h"

#include <algorithm>
#include <cmath>

#include "lslam_target/instruction_counter.h"
#include "lslam_target/semihosting.h"

namespace {

using lslam::target::Line;

constexpr std::int32_t kMaxSteps = 1024;
std::uint64_t g_sorted[kMaxSteps];  // scratch for medians (no heap)

// A kind without steps prints no summary (the 2D stream has no landmark observations).
constexpr StepKind kKinds[] = {StepKind::First,           StepKind::Odometry,
                               StepKind::LoopClosure,     StepKind::LandmarkObservation,
                               StepKind::Relinearization, StepKind::PrepareOrdering,
                               StepKind::Reorder,         StepKind::Layout};

const char* name(StepKind kind) {
  switch (kind) {
    case StepKind::First:
      return "first";
    case StepKind::Reorder:
      return "reorder";
    case StepKind::PrepareOrdering:
      return "prepare-ordering";
    case StepKind::Relinearization:
      return "relinearization";
    case StepKind::Layout:
      return "layout";
    case StepKind::LoopClosure:
      return "loop-closure";
    case StepKind::LandmarkObservation:
      return "landmark-observation";
    case StepKind::Odometry:
      return "odometry";
  }
  return "?";
}

void printStep(std::int32_t index, const StepCost& c) {
  Line()
      .text("step ")
      .integer(index)
      .text(" ")
      .text(name(c.kind))
      .text(" instructions ")
      .integer(static_cast<long long>(c.instructions))
      .text(" columns_refactored ")
      .integer(c.result.columns_refactored)
      .text(" block_products ")
      .integer(c.result.block_products)
      .text(" variables_solved ")
      .integer(c.result.variables_solved)
      .text(" relinearized ")
      .integer(c.result.variables_relinearized)
      .text(" factor_blocks ")
      .integer(c.result.factor_blocks)
      .text(" compacted ")
      .integer(c.result.compacted ? 1 : 0)
      .print();
}

// The counts of one kind of step, ascending, in g_sorted; returns how many.
std::int32_t sortedCounts(const StepCost* costs, std::int32_t count, StepKind kind) {
  std::int32_t n = 0;
  for (std::int32_t s = 0; s < count && n < kMaxSteps; ++s) {
    if (costs[s].kind == kind) g_sorted[n++] = costs[s].instructions;
  }
  std::sort(g_sorted, g_sorted + n);
  return n;
}

void printSummary(const StepCost* costs, std::int32_t count, StepKind kind) {
  const std::int32_t n = sortedCounts(costs, count, kind);
  if (n == 0) return;
  double sum = 0.0;
  for (std::int32_t i = 0; i < n; ++i) sum += static_cast<double>(g_sorted[i]);
  Line()
      .text("summary ")
      .text(name(kind))
      .text(": steps ")
      .integer(n)
      .text(" min ")
      .integer(static_cast<long long>(g_sorted[0]))
      .text(" median ")
      .integer(static_cast<long long>(g_sorted[n / 2]))
      .text(" mean ")
      .integer(std::llround(sum / n))
      .text(" max ")
      .integer(static_cast<long long>(g_sorted[n - 1]))
      .text(" instructions")
      .print();
}

struct Fit {
  double intercept = 0.0;
  double slope = 0.0;
  double r2 = 0.0;
  bool valid = false;
};

// Least squares instructions = intercept + slope * x over the steps of one kind.
template <typename Work>
Fit fit(const StepCost* costs, std::int32_t count, StepKind kind, Work work) {
  double n = 0, sx = 0, sy = 0, sxx = 0, sxy = 0, syy = 0;
  for (std::int32_t s = 0; s < count; ++s) {
    if (costs[s].kind != kind) continue;
    const double x = work(s, costs[s].result);
    const double y = static_cast<double>(costs[s].instructions);
    n += 1;
    sx += x;
    sy += y;
    sxx += x * x;
    sxy += x * y;
    syy += y * y;
  }
  Fit f;
  const double cxx = sxx - sx * sx / n, cxy = sxy - sx * sy / n, cyy = syy - sy * sy / n;
  if (n < 2 || cxx <= 0 || cyy <= 0) return f;
  f.slope = cxy / cxx;
  f.intercept = (sy - f.slope * sx) / n;
  f.r2 = cxy * cxy / (cxx * cyy);
  f.valid = true;
  return f;
}

template <typename Work>
void printLoopClosureFit(const StepCost* costs, std::int32_t count, const char* what, Work work) {
  const Fit f = fit(costs, count, StepKind::LoopClosure, work);
  if (!f.valid) return;
  Line()
      .text("loop-closure fit: instructions = ")
      .real(f.intercept, 4)
      .text(" + ")
      .real(f.slope, 4)
      .text(" * ")
      .text(what)
      .text(", R^2 = ")
      .real(f.r2, 4)
      .print();
}

// Odometry: first, last, median, spread and the least-squares trend over the stream. The spread
// is taken over the steps that back-substitute as many variables as the first one: the partial
// back-substitution occasionally solves one more variable, which is more work, not drift.
OdometryFigures printOdometry(const StepCost* costs, std::int32_t count) {
  OdometryFigures figures;
  std::int32_t first = -1, last = -1;
  for (std::int32_t s = 0; s < count; ++s) {
    if (costs[s].kind != StepKind::Odometry) continue;
    if (first < 0) first = s;
    last = s;
  }
  const std::int32_t n = sortedCounts(costs, count, StepKind::Odometry);
  if (n == 0) return figures;
  const double median = static_cast<double>(g_sorted[n / 2]);
  const double first_count = static_cast<double>(costs[first].instructions);
  figures.first_to_last =
      100.0 * (static_cast<double>(costs[last].instructions) - first_count) / first_count;
  std::uint64_t min = ~std::uint64_t{0}, max = 0;
  std::int32_t same_work = 0;
  for (std::int32_t s = first; s <= last; ++s) {
    if (costs[s].kind != StepKind::Odometry ||
        costs[s].result.variables_solved != costs[first].result.variables_solved) {
      continue;
    }
    min = std::min(min, costs[s].instructions);
    max = std::max(max, costs[s].instructions);
    ++same_work;
  }
  figures.spread = 100.0 * static_cast<double>(max - min) / static_cast<double>(min);
  const Fit trend = fit(costs, count, StepKind::Odometry,
                        [](std::int32_t s, const lslam::UpdateResult&) { return double(s); });
  figures.trend = 100.0 * trend.slope * (last - first) / median;
  Line()
      .text("odometry (")
      .integer(n)
      .text(" steps): first (step ")
      .integer(first)
      .text(") ")
      .integer(static_cast<long long>(costs[first].instructions))
      .text(", last (step ")
      .integer(last)
      .text(") ")
      .integer(static_cast<long long>(costs[last].instructions))
      .text(", median ")
      .integer(static_cast<long long>(median))
      .text("; last - first = ")
      .fixed(figures.first_to_last, 2)
      .text(" %, (max - min) / min over the ")
      .integer(same_work)
      .text(" steps solving ")
      .integer(costs[first].result.variables_solved)
      .text(" variables = ")
      .fixed(figures.spread, 2)
      .text(" %, fitted trend = ")
      .fixed(figures.trend, 2)
      .text(" % of the median")
      .print();
  return figures;
}

void printWorstLoopClosure(const StepCost* costs, std::int32_t count) {
  std::int32_t worst = -1;
  for (std::int32_t s = 0; s < count; ++s) {
    if (costs[s].kind != StepKind::LoopClosure) continue;
    if (worst < 0 || costs[s].instructions > costs[worst].instructions) worst = s;
  }
  if (worst < 0) return;
  Line().text("worst loop-closure step:").print();
  printStep(worst, costs[worst]);
  printLoopClosureFit(costs, count, "block_products",
                      [](std::int32_t, const lslam::UpdateResult& r) {
                        return static_cast<double>(r.block_products);
                      });
  printLoopClosureFit(costs, count, "columns_refactored",
                      [](std::int32_t, const lslam::UpdateResult& r) {
                        return static_cast<double>(r.columns_refactored);
                      });
  printLoopClosureFit(costs, count, "variables_solved",
                      [](std::int32_t, const lslam::UpdateResult& r) {
                        return static_cast<double>(r.variables_solved);
                      });
}

}  // namespace

StepKind stepKind(bool first, bool loop_closure, bool landmark_observation,
                  const lslam::UpdateResult& result) {
  if (first) return StepKind::First;
  if (result.reordered) return StepKind::Reorder;
  if (result.ordering_prepared) return StepKind::PrepareOrdering;
  if (result.variables_relinearized > 0) return StepKind::Relinearization;
  if (result.laid_out) return StepKind::Layout;
  if (loop_closure) return StepKind::LoopClosure;
  return landmark_observation ? StepKind::LandmarkObservation : StepKind::Odometry;
}

OdometryFigures printStepCosts(const StepCost* costs, std::int32_t count) {
  Line()
      .text("instructions per step (update + solve; QEMU -icount shift=0, resolution ")
      .integer(static_cast<long long>(lslam::target::kInstructionsPerTick))
      .text("):")
      .print();
  for (std::int32_t s = 0; s < count; ++s) printStep(s, costs[s]);
  for (StepKind kind : kKinds) printSummary(costs, count, kind);
  const OdometryFigures odometry = printOdometry(costs, count);
  printWorstLoopClosure(costs, count);
  return odometry;
}
