// Must NOT link: operator new (libstdc++) calls malloc, which the link guard forbids.
int main() {
  int* volatile p = new int[4];
  delete[] p;
  return 0;
}
