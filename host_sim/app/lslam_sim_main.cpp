#include <cstdio>

int main() {
  std::puts("lslam-sim: not built yet");
  return 1;
}
