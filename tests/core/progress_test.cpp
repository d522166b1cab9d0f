// The progress bar's estimate of the time left (core/progress.h): the pace so far, carried on.
#include "penumbra/core/progress.h"

#include <gtest/gtest.h>

namespace penumbra {
namespace {

TEST(Progress, TimeLeftCarriesThePaceSoFarOn) {
  EXPECT_EQ(formatTimeLeft(10.0, 0.5), "10 s left");
  EXPECT_EQ(formatTimeLeft(30.0, 0.25), "1 min 30 s left");
  EXPECT_EQ(formatTimeLeft(65.0, 0.01), "1 h 47 min left");  // 6435 s
  // Too early to tell: under 1% done or under a second spent; nothing once done.
  EXPECT_EQ(formatTimeLeft(100.0, 0.005), "");
  EXPECT_EQ(formatTimeLeft(0.5, 0.5), "");
  EXPECT_EQ(formatTimeLeft(10.0, 1.0), "");
  EXPECT_EQ(formatTimeLeft(10.0, -0.1), "");
}

}  // namespace
}  // namespace penumbra
