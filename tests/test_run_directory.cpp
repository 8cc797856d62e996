// The run loop and its output directory (issue 12: counts, restarts, stale outputs, live history).
#include <gtest/gtest.h>
