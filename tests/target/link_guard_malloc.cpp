// Must NOT link: it calls malloc, which the link guard forbids (see expect_link_failure.cmake).
#include <cstdlib>

int main() {
  void* volatile p = std::malloc(16);
  std::free(p);
  return 0;
}
