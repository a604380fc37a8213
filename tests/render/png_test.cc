#include "render/png.h"

#include <cstdint>
#include <random>
#include <string>
#include <vector>

#include "gmock/gmock.h"
#include "gtest/gtest.h"
#include "opencv2/core.hpp"
#include "opencv2/imgcodecs.hpp"

namespace oaipp::render {
namespace {

using ::testing::HasSubstr;

// libpng writes, OpenCV's own decoder (a different code path, its imgcodecs
// build) reads back: every pixel must come back as it went in.
TEST(PngTest, OpenCvDecodesEveryPixelAsWritten) {
  std::mt19937 rng(7);
  std::uniform_int_distribution<int> byte(0, 255);
  // Odd sizes, and a stride with padding after each row, as a sub-image has.
  const int width = 37, height = 23;
  const std::size_t stride = 3 * width + 5;
  std::vector<std::uint8_t> bgr(stride * height);
  for (std::uint8_t& b : bgr) b = static_cast<std::uint8_t>(byte(rng));

  absl::StatusOr<std::string> png = EncodePngBgr(bgr.data(), width, height, stride);
  ASSERT_TRUE(png.ok()) << png.status();
  ASSERT_GE(png->size(), 8u);
  EXPECT_EQ(png->substr(1, 3), "PNG");

  const std::vector<std::uint8_t> bytes(png->begin(), png->end());
  const cv::Mat decoded = cv::imdecode(bytes, cv::IMREAD_UNCHANGED);
  ASSERT_EQ(decoded.type(), CV_8UC3);  // colour, no alpha
  ASSERT_EQ(decoded.cols, width);
  ASSERT_EQ(decoded.rows, height);
  int differing = 0;
  for (int r = 0; r < height; ++r) {
    for (int c = 0; c < width; ++c) {
      const cv::Vec3b got = decoded.at<cv::Vec3b>(r, c);  // OpenCV's BGR
      for (int k = 0; k < 3; ++k) differing += got[k] != bgr[r * stride + 3 * c + k];
    }
  }
  EXPECT_EQ(differing, 0);
}

TEST(PngTest, RefusesEmptyImagesAndShortStrides) {
  const std::vector<std::uint8_t> bgr(3 * 4 * 4, 0);
  EXPECT_THAT(EncodePngBgr(bgr.data(), 0, 4, 12).status().message(), HasSubstr("0 x 4"));
  EXPECT_THAT(EncodePngBgr(nullptr, 4, 4, 12).status().message(), HasSubstr("nothing"));
  const absl::Status short_stride = EncodePngBgr(bgr.data(), 4, 4, 11).status();
  EXPECT_EQ(short_stride.code(), absl::StatusCode::kInvalidArgument);
  EXPECT_THAT(short_stride.message(), HasSubstr("stride of 11"));
}

}  // namespace
}  // namespace oaipp::render
