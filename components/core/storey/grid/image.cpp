#include "storey/grid/image.h"

#include <zlib.h>

#include <array>
#include <cstring>
#include <fstream>
#include <iterator>
#include <stdexcept>

#include "storey/common/file_checks.h"
#include "storey/grid/grid2.h"

namespace storey::grid {
namespace {

void putU32(std::vector<std::uint8_t>& out, std::uint32_t v) {
  out.push_back(static_cast<std::uint8_t>(v >> 24));
  out.push_back(static_cast<std::uint8_t>(v >> 16));
  out.push_back(static_cast<std::uint8_t>(v >> 8));
  out.push_back(static_cast<std::uint8_t>(v));
}

std::uint32_t getU32(const std::uint8_t* p) {
  return (std::uint32_t(p[0]) << 24) | (std::uint32_t(p[1]) << 16) | (std::uint32_t(p[2]) << 8) | p[3];
}

void putChunk(std::vector<std::uint8_t>& out, const char* type, const std::vector<std::uint8_t>& data) {
  putU32(out, static_cast<std::uint32_t>(data.size()));
  const std::size_t start = out.size();
  out.insert(out.end(), type, type + 4);
  out.insert(out.end(), data.begin(), data.end());
  putU32(out, static_cast<std::uint32_t>(crc32(0L, &out[start], static_cast<uInt>(out.size() - start))));
}

constexpr std::array<std::uint8_t, 8> kSignature{137, 80, 78, 71, 13, 10, 26, 10};

}  // namespace

void writePng(const std::string& path, const Image& image) {
  if (image.width <= 0 || image.height <= 0 || (image.channels != 1 && image.channels != 3))
    throw std::runtime_error(path + ": cannot write an empty or unsupported image");
  const std::size_t row_bytes = static_cast<std::size_t>(image.width) * image.channels;
  std::vector<std::uint8_t> raw;
  raw.reserve((row_bytes + 1) * image.height);
  for (int y = 0; y < image.height; ++y) {
    raw.push_back(0);  // filter type: none
    const std::uint8_t* row = image.at(0, y);
    raw.insert(raw.end(), row, row + row_bytes);
  }
  uLongf compressed_size = compressBound(static_cast<uLong>(raw.size()));
  std::vector<std::uint8_t> compressed(compressed_size);
  if (compress2(compressed.data(), &compressed_size, raw.data(), static_cast<uLong>(raw.size()), 6) != Z_OK)
    throw std::runtime_error(path + ": compression failed");
  compressed.resize(compressed_size);

  std::vector<std::uint8_t> file(kSignature.begin(), kSignature.end());
  std::vector<std::uint8_t> header;
  putU32(header, static_cast<std::uint32_t>(image.width));
  putU32(header, static_cast<std::uint32_t>(image.height));
  header.push_back(8);                           // bit depth
  header.push_back(image.channels == 1 ? 0 : 2);  // colour type: grey or RGB
  header.push_back(0);
  header.push_back(0);
  header.push_back(0);
  putChunk(file, "IHDR", header);
  putChunk(file, "IDAT", compressed);
  putChunk(file, "IEND", {});
  std::ofstream out(path, std::ios::binary);
  if (!out) throw std::runtime_error(path + ": cannot open for writing");
  out.write(reinterpret_cast<const char*>(file.data()), static_cast<std::streamsize>(file.size()));
  if (!out) throw std::runtime_error(path + ": write failed");
}

Image readPng(const std::string& path) {
  common::requireRegularFile(path, "PNG file", 1ull << 30);
  std::ifstream in(path, std::ios::binary);
  if (!in) throw std::runtime_error(path + ": cannot open");
  std::vector<std::uint8_t> file((std::istreambuf_iterator<char>(in)), std::istreambuf_iterator<char>());
  if (file.size() < 8 || std::memcmp(file.data(), kSignature.data(), 8) != 0)
    throw std::runtime_error(path + ": not a PNG file");
  Image image;
  std::vector<std::uint8_t> compressed;
  std::size_t pos = 8;
  while (pos + 12 <= file.size()) {
    const std::uint32_t length = getU32(&file[pos]);
    if (pos + 12 + length > file.size()) throw std::runtime_error(path + ": truncated PNG chunk");
    const std::string type(reinterpret_cast<const char*>(&file[pos + 4]), 4);
    const std::uint8_t* data = &file[pos + 8];
    if (type == "IHDR") {
      image.width = static_cast<int>(getU32(data));
      image.height = static_cast<int>(getU32(data + 4));
      if (data[8] != 8 || (data[9] != 0 && data[9] != 2) || data[12] != 0)
        throw std::runtime_error(path + ": unsupported PNG layout (only 8-bit grey/RGB)");
      image.channels = data[9] == 0 ? 1 : 3;
    } else if (type == "IDAT") {
      compressed.insert(compressed.end(), data, data + length);
    } else if (type == "IEND") {
      break;
    }
    pos += 12 + length;
  }
  if (image.width <= 0 || image.height <= 0) throw std::runtime_error(path + ": missing PNG header");
  if (static_cast<double>(image.width) * image.height > kMaxGridCells)
    throw std::runtime_error(path + ": " + std::to_string(image.width) + " x " +
                             std::to_string(image.height) + " pixels, more than the " +
                             std::to_string(static_cast<long>(kMaxGridCells)) +
                             " a picture may have");
  const std::size_t row_bytes = static_cast<std::size_t>(image.width) * image.channels;
  std::vector<std::uint8_t> raw((row_bytes + 1) * image.height);
  uLongf raw_size = static_cast<uLongf>(raw.size());
  if (uncompress(raw.data(), &raw_size, compressed.data(), static_cast<uLong>(compressed.size())) != Z_OK ||
      raw_size != raw.size())
    throw std::runtime_error(path + ": corrupt PNG data");
  image.pixels.resize(row_bytes * image.height);
  for (int y = 0; y < image.height; ++y) {
    if (raw[y * (row_bytes + 1)] != 0) throw std::runtime_error(path + ": unsupported PNG filter");
    std::memcpy(&image.pixels[y * row_bytes], &raw[y * (row_bytes + 1) + 1], row_bytes);
  }
  return image;
}

void writePgm(const std::string& path, const Image& grey) {
  if (grey.channels != 1) throw std::runtime_error(path + ": PGM needs a grey image");
  std::ofstream out(path, std::ios::binary);
  if (!out) throw std::runtime_error(path + ": cannot open for writing");
  out << "P5\n" << grey.width << " " << grey.height << "\n255\n";
  out.write(reinterpret_cast<const char*>(grey.pixels.data()), static_cast<std::streamsize>(grey.pixels.size()));
  if (!out) throw std::runtime_error(path + ": write failed");
}

void drawLine(Image& image, int x0, int y0, int x1, int y1,
              const std::array<std::uint8_t, 3>& colour) {
  const int dx = std::abs(x1 - x0), dy = -std::abs(y1 - y0);
  const int sx = x0 < x1 ? 1 : -1, sy = y0 < y1 ? 1 : -1;
  int err = dx + dy;
  while (true) {
    if (x0 >= 0 && y0 >= 0 && x0 < image.width && y0 < image.height)
      std::copy(colour.begin(), colour.end(), image.at(x0, y0));
    if (x0 == x1 && y0 == y1) break;
    const int e2 = 2 * err;
    if (e2 >= dy) {
      err += dy;
      x0 += sx;
    }
    if (e2 <= dx) {
      err += dx;
      y0 += sy;
    }
  }
}

}  // namespace storey::grid
