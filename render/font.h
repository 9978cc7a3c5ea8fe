// A small built-in 5x7 bitmap font drawn straight into an Image (HUD, legend).
// Letters are drawn as capitals; characters without a glyph as '?'.
#pragma once

#include <string>

#include "render/image.h"

namespace gs::render {

struct Rgb {
  uint8_t r = 255, g = 255, b = 255;
};

/// Width and height in pixels of `text` at integer `scale` (one glyph cell is 6x9).
int TextWidth(const std::string& text, int scale);
int TextHeight(int scale);

/// Draws `text` with its top-left corner at (x, y); clipped to the image.
void DrawText(Image* img, int x, int y, const std::string& text, int scale, Rgb color);

/// Blends a rectangle of `color` with opacity `alpha` in [0, 1]; clipped.
void FillRect(Image* img, int x, int y, int w, int h, Rgb color, double alpha);

}  // namespace gs::render
