// An 8-bit RGBA image, rows top to bottom.
#pragma once

#include <cstdint>
#include <vector>

namespace gs::render {

struct Image {
  int width = 0, height = 0;
  std::vector<uint8_t> rgba;  ///< width * height * 4, row 0 at the top

  void Resize(int w, int h) {
    width = w;
    height = h;
    rgba.assign(static_cast<size_t>(w) * h * 4, 0);
  }
  uint8_t* At(int x, int y) { return rgba.data() + (static_cast<size_t>(y) * width + x) * 4; }
  const uint8_t* At(int x, int y) const { return rgba.data() + (static_cast<size_t>(y) * width + x) * 4; }
};

}  // namespace gs::render
