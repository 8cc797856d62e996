// Bed analysis: exact sphere-box volumes, empty or too-small regions, clusters.
#include <gtest/gtest.h>
