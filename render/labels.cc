#include "render/labels.h"

#include <cstdio>

namespace oaipp::render::labels {

TextExtent MeasureText(const std::string& text, const Font& font) {
  int baseline = 0;
  const cv::Size size = cv::getTextSize(text, kFontFace, font.scale, font.thickness, &baseline);
  return {size.width, size.height, baseline};
}

void PutText(cv::Mat& image, const std::string& text, int x, int y, HAlign h, VAlign v,
             const Font& font) {
  const TextExtent e = MeasureText(text, font);
  const int left = h == HAlign::kLeft ? x : h == HAlign::kCentre ? x - e.width / 2 : x - e.width;
  const int baseline = v == VAlign::kTop ? y + e.cap : y + e.cap / 2;
  cv::putText(image, text, cv::Point(left, baseline), kFontFace, font.scale, kBlack, font.thickness,
              cv::LINE_AA);
}

int UpTextWidth(const std::string& text, const Font& font) {
  const TextExtent e = MeasureText(text, font);
  return e.cap + e.descent + 2 * (font.thickness + 1);
}

void PutTextUp(cv::Mat& image, const std::string& text, int cx, int cy, const Font& font) {
  const TextExtent e = MeasureText(text, font);
  const int pad = font.thickness + 1;
  cv::Mat flat(e.cap + e.descent + 2 * pad, e.width + 2 * pad, CV_8UC3, kWhite);
  cv::putText(flat, text, cv::Point(pad, pad + e.cap), kFontFace, font.scale, kBlack,
              font.thickness, cv::LINE_AA);
  cv::Mat up;
  cv::rotate(flat, up, cv::ROTATE_90_COUNTERCLOCKWISE);
  const cv::Rect where(cx - up.cols / 2, cy - up.rows / 2, up.cols, up.rows);
  const cv::Rect inside = where & cv::Rect(0, 0, image.cols, image.rows);
  if (inside.empty()) return;
  cv::Mat target = image(inside);
  cv::min(target, up(inside - where.tl()), target);
}

double NiceStep(double range, int max_ticks) {
  const double raw = range / std::max(max_ticks, 1);
  const double magnitude = std::pow(10.0, std::floor(std::log10(raw)));
  for (const double m : {1.0, 2.0, 5.0}) {
    if (m * magnitude >= raw * (1 - 1e-9)) return m * magnitude;
  }
  return 10.0 * magnitude;
}

int DecimalsFor(double step) {
  return std::max(0, static_cast<int>(-std::floor(std::log10(step) + 1e-9)));
}

std::string FormatNumber(double value, int decimals) {
  char buffer[64];
  std::snprintf(buffer, sizeof(buffer), "%.*f", decimals, value);
  std::string text(buffer);
  if (text.front() == '-' && text.find_first_not_of("-0.") == std::string::npos) text.erase(0, 1);
  return text;
}

}  // namespace oaipp::render::labels
