// PNG and PGM writing for maps and figures (8-bit grey or RGB, zlib-compressed).
#pragma once

#include <array>
#include <cstdint>
#include <string>
#include <vector>

namespace storey::grid {

struct Image {
  int width = 0;
  int height = 0;
  int channels = 1;  // 1 grey, 3 RGB
  std::vector<std::uint8_t> pixels;  // row-major, top row first

  Image() = default;
  Image(int w, int h, int c, std::uint8_t fill = 255)
      : width(w), height(h), channels(c), pixels(static_cast<std::size_t>(w) * h * c, fill) {}
  std::uint8_t* at(int x, int y) { return &pixels[(static_cast<std::size_t>(y) * width + x) * channels]; }
  const std::uint8_t* at(int x, int y) const {
    return &pixels[(static_cast<std::size_t>(y) * width + x) * channels];
  }
};

// A straight line of `colour` from (x0, y0) to (x1, y1) on an RGB image (Bresenham);
// the part outside the image is left out.
void drawLine(Image& image, int x0, int y0, int x1, int y1,
              const std::array<std::uint8_t, 3>& colour);

// Throws std::runtime_error naming the path on failure.
void writePng(const std::string& path, const Image& image);
// Reads a PNG written by writePng (8-bit grey/RGB, no interlace); throws on anything else.
Image readPng(const std::string& path);
void writePgm(const std::string& path, const Image& grey);

}  // namespace storey::grid
