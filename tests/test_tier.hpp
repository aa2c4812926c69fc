#pragma once
// The tier of GoogleTest cases, written next to them:
//   RGBDMAP_TEST_TIER("Suite.*", "e2e");              end to end on synthetic or real data
//   RGBDMAP_TEST_TIER("Suite.Case", "e2e sanitize");  end to end, and again under ASan + UBSan
//   RGBDMAP_TEST_TIER("Suite.Case", "accuracy");      an accuracy bound on a whole sequence (Release only)
//   RGBDMAP_TEST_TIER("Net*", "elsewhere");           run by another CTest test (e.g. in a network namespace)
// The first argument is a GoogleTest filter pattern. Every case no pattern names is unit (and sanitize).
// tests/cmake/test_suite.cmake reads these lines from the sources at configure time; here the macro only
// checks that both arguments are string literals.
#define RGBDMAP_TEST_TIER(pattern, labels) \
  static_assert(sizeof(pattern "") > 1 && sizeof(labels "") > 1, "RGBDMAP_TEST_TIER(pattern, labels)")
