// Text and axis ticks for the map picture (render/map_render.cc): OpenCV's
// Hershey font placed by its capital height, labels turned to read upwards,
// and 1-2-5 tick steps whose labels do not overlap. Internal to the render
// library; its OpenCV types stay out of render/map_render.h.
#pragma once

#include <algorithm>
#include <cmath>
#include <string>
#include <vector>

#include "opencv2/core.hpp"
#include "opencv2/imgproc.hpp"

namespace oaipp::render::labels {

inline const cv::Scalar kWhite(255, 255, 255);
inline const cv::Scalar kBlack(0, 0, 0);
constexpr int kFontFace = cv::FONT_HERSHEY_SIMPLEX;

struct Font {
  double scale = 0.45;
  int thickness = 1;
};

struct TextExtent {
  int width = 0;
  int cap = 0;      // height above the baseline
  int descent = 0;  // below it
};

TextExtent MeasureText(const std::string& text, const Font& font);

enum class HAlign { kLeft, kCentre, kRight };
enum class VAlign { kTop, kMiddle };

// Writes `text` horizontally, its box placed against (x, y) as the alignments
// say (vertical alignment by the capital height, descenders hang below).
void PutText(cv::Mat& image, const std::string& text, int x, int y, HAlign h, VAlign v,
             const Font& font);

// Width a PutTextUp label takes across the page.
int UpTextWidth(const std::string& text, const Font& font);

// Writes `text` reading bottom to top (turned 90 degrees counter-clockwise),
// centred on (cx, cy). Drawn on white and laid over the image by darkening,
// so it only adds black ink.
void PutTextUp(cv::Mat& image, const std::string& text, int cx, int cy, const Font& font);

// The smallest of 1, 2, 5 x 10^n that is >= range / max_ticks.
double NiceStep(double range, int max_ticks);

// Decimals needed to print multiples of a 1-2-5 step.
int DecimalsFor(double step);

// `value` with `decimals` decimals, never "-0".
std::string FormatNumber(double value, int decimals);

struct Tick {
  double value = 0.0;
  std::string label;
};

struct Ticks {
  double step = 1.0;
  std::vector<Tick> ticks;
};

// Multiples of a 1-2-5 step (at least min_step) in [lo, hi], at most one per
// min_spacing_px (the axis spans span_px for the range) and far enough apart
// that labels do not overlap: label_width(label) is the room a label needs
// along the axis.
template <typename Width>
Ticks MakeTicks(double lo, double hi, int span_px, double min_spacing_px, Width label_width,
                double min_step = 0.0) {
  const double range = hi - lo;
  double step = std::max(NiceStep(range, static_cast<int>(span_px / min_spacing_px)), min_step);
  std::vector<Tick> ticks;
  for (int attempt = 0; attempt < 64; ++attempt) {
    ticks.clear();
    const int decimals = DecimalsFor(step);
    const double first = std::ceil(lo / step - 1e-9);
    const double last = std::floor(hi / step + 1e-9);
    int widest = 0;
    for (double i = first; i <= last; i += 1.0) {
      Tick tick{i * step, FormatNumber(i * step, decimals)};
      widest = std::max(widest, label_width(tick.label));
      ticks.push_back(std::move(tick));
    }
    const double step_px = step / range * span_px;
    if (ticks.size() <= 1 || step_px >= widest) break;
    step = NiceStep(1.5 * step, 1);  // the next 1-2-5 step
  }
  return {step, std::move(ticks)};
}

}  // namespace oaipp::render::labels
