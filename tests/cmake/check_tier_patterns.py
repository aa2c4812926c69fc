#!/usr/bin/env python3
"""Checks that every RGBDMAP_TEST_TIER pattern of a GoogleTest executable names at least one of its cases
(a pattern that names none would leave the cases it meant in the unit tier).

usage: check_tier_patterns.py EXECUTABLE PATTERN...
Exit 0 when each pattern matches a case, 1 naming the patterns that match none, 2 when the executable
cannot list its cases."""
import subprocess
import sys


def main():
    exe, patterns = sys.argv[1], sys.argv[2:]
    missing = []
    for pattern in patterns:
        try:
            out = subprocess.run([exe, "--gtest_list_tests", f"--gtest_filter={pattern}"], capture_output=True,
                                 text=True, timeout=60, check=True).stdout
        except (OSError, subprocess.SubprocessError) as e:
            print(f"{exe}: cannot list its tests: {e}")
            return 2
        if not any(line.startswith("  ") for line in out.splitlines()):
            missing.append(pattern)
    for pattern in missing:
        print(f"{exe}: the tier pattern {pattern} names no test")
    print(f"{len(patterns) - len(missing)} of {len(patterns)} tier patterns name tests")
    return 1 if missing else 0


if __name__ == "__main__":
    sys.exit(main())
