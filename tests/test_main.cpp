#define DOCTEST_CONFIG_IMPLEMENT
#include <doctest/doctest.h>

#include <cstdio>
#include <cstdlib>

#include "lslam/assert.h"

namespace {
void printAndAbort(const char* expression, const char* file, int line) {
  std::fprintf(stderr, "lslam assertion failed: %s (%s:%d)\n", expression, file, line);
  std::abort();
}
}  // namespace

int main(int argc, char** argv) {
  lslam::setAssertHandler(&printAndAbort);
  doctest::Context context(argc, argv);
  return context.run();
}
