#include <gtest/gtest.h>

#include "tsf/common/cuda_support.h"

namespace tsf {
namespace {

TEST(CudaSupport, StatusIsConsistentAndExplainsAbsence) {
  const CudaStatus& s = cuda_status();
  if (!s.available) {
    EXPECT_FALSE(s.reason.empty()) << "an unavailable backend must say why";
    EXPECT_EQ(s.device_count, 0);
    GTEST_SKIP() << "CUDA backend not usable here: " << s.reason;
  }
  EXPECT_TRUE(s.compiled);
  EXPECT_GT(s.device_count, 0);
  EXPECT_FALSE(s.device_name.empty());
  EXPECT_TRUE(s.reason.empty());
}

}  // namespace
}  // namespace tsf
