// tests/fuzz/fuzz_check.h: the contract check every fuzz target makes besides
// the sanitizers' own findings.
//
//   Check(!error.message.empty(), "a refusal says why");
#ifndef GEARLOOP_TESTS_FUZZ_FUZZ_CHECK_H_
#define GEARLOOP_TESTS_FUZZ_FUZZ_CHECK_H_

#include <cstdio>
#include <cstdlib>

namespace gearloop {
namespace fuzz {

// Aborts (a libFuzzer crash with the input saved) when `condition` does not
// hold, naming what was violated.
inline void Check(bool condition, const char* what) {
  if (!condition) {
    std::fprintf(stderr, "contract violated: %s\n", what);
    std::abort();
  }
}

}  // namespace fuzz
}  // namespace gearloop

#endif  // GEARLOOP_TESTS_FUZZ_FUZZ_CHECK_H_
