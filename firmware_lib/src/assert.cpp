#include "lslam/assert.h"

namespace lslam {
namespace {

void trapHandler(const char*, const char*, int) {
  __builtin_trap();
}

AssertHandler g_assert_handler = &trapHandler;

}  // namespace

AssertHandler setAssertHandler(AssertHandler handler) noexcept {
  AssertHandler previous = g_assert_handler;
  g_assert_handler = handler != nullptr ? handler : &trapHandler;
  return previous;
}

void assertFailed(const char* expression, const char* file, int line) noexcept {
  g_assert_handler(expression, file, line);
  __builtin_trap();  // a handler that returns must not let execution continue
}

}  // namespace lslam
