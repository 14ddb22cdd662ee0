#!/usr/bin/python3
"""Counts the test cases of a catkin test run, each once.

usage: count_tests.py TEST_RESULTS_DIR

Reads every JUnit XML file under TEST_RESULTS_DIR and prints two numbers:
its <testcase> elements, and those of them that hold a <failure> or an
<error>. catkin_test_results sums the `tests` attributes instead, which
counts every gtest case twice (gtest's XML states the total on <testsuites>
and again on each <testsuite>).
"""

import glob
import os
import sys
import xml.etree.ElementTree as ElementTree


def count_cases(results_dir):
    cases = failed = 0
    for path in glob.glob(os.path.join(results_dir, "**", "*.xml"), recursive=True):
        for case in ElementTree.parse(path).getroot().iter("testcase"):
            cases += 1
            if case.find("failure") is not None or case.find("error") is not None:
                failed += 1
    return cases, failed


def main(argv):
    if len(argv) != 2:
        print(__doc__, file=sys.stderr)
        return 2
    cases, failed = count_cases(argv[1])
    print(cases, failed)
    return 0


if __name__ == "__main__":
    sys.exit(main(sys.argv))
