// The time-step guard: damper stability, tool speed, non-finite derived quantities.
#include <gtest/gtest.h>
