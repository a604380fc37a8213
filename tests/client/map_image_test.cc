// The frame montage and the mission video of oaipp-client run --frames.
#include <cstdint>
#include <filesystem>
#include <string>
#include <vector>

#include "client/cli/map_image.h"
#include "gtest/gtest.h"
#include "opencv2/imgcodecs.hpp"
#include "opencv2/videoio.hpp"

namespace oaipp::client {
namespace {

TEST(MontageTest, TilesFramesWithCaptions) {
  std::vector<std::uint8_t> bytes;
  ASSERT_TRUE(cv::imencode(".png", cv::Mat(50, 80, CV_8UC3, cv::Scalar(10, 20, 30)), bytes));
  const std::string frame(bytes.begin(), bytes.end());
  absl::StatusOr<std::string> sheet = MontagePng({frame, frame, frame}, {"a", "b", "c"}, 2);
  ASSERT_TRUE(sheet.ok()) << sheet.status();
  const cv::Mat image =
      cv::imdecode(std::vector<std::uint8_t>(sheet->begin(), sheet->end()), cv::IMREAD_COLOR);
  EXPECT_EQ(image.cols, 160);            // two columns of 80 px
  EXPECT_EQ(image.rows, 2 * (50 + 36));  // two rows, each with a 36 px caption band
  EXPECT_EQ(MontagePng({frame}, {}, 2).status().code(), absl::StatusCode::kInvalidArgument);
  EXPECT_EQ(MontagePng({"not a png"}, {"x"}, 2).status().code(),
            absl::StatusCode::kInvalidArgument);
}

TEST(MontageTest, VideoHoldsEveryFrameWithItsCaption) {
  std::vector<std::string> frames;
  for (int i = 0; i < 3; ++i) {
    std::vector<std::uint8_t> bytes;
    // Frames of different brightness; the second one half as wide (scaled up).
    const cv::Mat m(50, i == 1 ? 40 : 80, CV_8UC3, cv::Scalar::all(60.0 * (i + 1)));
    ASSERT_TRUE(cv::imencode(".png", m, bytes));
    frames.emplace_back(bytes.begin(), bytes.end());
  }
  const std::string path = ::testing::TempDir() + "/oaipp_video_test.avi";
  ASSERT_TRUE(WriteVideo(frames, {"a", "b", "c"}, 2.0, path).ok());
  cv::VideoCapture video(path, cv::CAP_OPENCV_MJPEG);
  ASSERT_TRUE(video.isOpened());
  EXPECT_EQ(video.get(cv::CAP_PROP_FRAME_COUNT), 3);
  EXPECT_NEAR(video.get(cv::CAP_PROP_FPS), 2.0, 1e-9);
  for (int i = 0; i < 3; ++i) {
    cv::Mat frame;
    ASSERT_TRUE(video.read(frame)) << "frame " << i;
    EXPECT_EQ(frame.cols, 80);
    EXPECT_EQ(frame.rows, 50 + 36);  // the caption band on top
    // Below the caption band the frame keeps its brightness (JPEG: +-4).
    const cv::Scalar mean = cv::mean(frame(cv::Rect(10, 50, 60, 30)));
    EXPECT_NEAR(mean[1], 60.0 * (i + 1), 4.0) << "frame " << i;
  }
  EXPECT_EQ(WriteVideo(frames, {"a", "b", "c"}, 0.0, path).code(),
            absl::StatusCode::kInvalidArgument);
  EXPECT_EQ(WriteVideo(frames, {"a"}, 2.0, path).code(), absl::StatusCode::kInvalidArgument);
  EXPECT_EQ(WriteVideo(frames, {"a", "b", "c"}, 2.0, "/nonexistent-dir/x.avi").code(),
            absl::StatusCode::kInternal);
}

}  // namespace
}  // namespace oaipp::client
