// Case-reader checks (issue 12: overlaps, counts, materials, periodic axes, --set paths).
#include <gtest/gtest.h>
