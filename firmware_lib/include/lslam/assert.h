#pragma once
// Programmer errors (a broken precondition, never bad input) go through one replaceable handler,
// as in ETL: firmware decides whether that means a reset, a log entry or a debugger break.
// Bad *input* is never asserted on: it is reported with a Status (see status.h).

namespace lslam {

using AssertHandler = void (*)(const char* expression, const char* file, int line);

// Installs `handler` (nullptr restores the default, which traps). Returns the previous handler.
AssertHandler setAssertHandler(AssertHandler handler) noexcept;

// Calls the installed handler; if the handler returns, traps: execution must not go on past a
// broken invariant.
[[noreturn]] void assertFailed(const char* expression, const char* file, int line) noexcept;

}  // namespace lslam

// Always on: cheap checks at API boundaries.
#define LSLAM_ASSERT(cond) \
  ((cond) ? static_cast<void>(0) : ::lslam::assertFailed(#cond, __FILE__, __LINE__))

// On only in builds without NDEBUG: checks inside hot loops.
#ifdef NDEBUG
#define LSLAM_DEBUG_ASSERT(cond) static_cast<void>(0)
#else
#define LSLAM_DEBUG_ASSERT(cond) LSLAM_ASSERT(cond)
#endif
