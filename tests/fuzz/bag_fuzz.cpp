// The bag reader (storey::bag) on a corrupt .db3: raw bytes, or a valid bag written by
// BagWriter patched by the input (fuzz_support.h), read to the end.
#include <cstdint>
#include <filesystem>
#include <fstream>
#include <iterator>
#include <stdexcept>
#include <vector>

#include "fuzz_support.h"
#include "storey/bag/bag_error.h"
#include "storey/bag/bag_reader.h"
#include "storey/bag/bag_writer.h"
#include "storey/common/log.h"

namespace fs = std::filesystem;

namespace {

std::vector<std::uint8_t> sampleDb3() {
  const fs::path folder = fs::path(storey::fuzz::fuzzTempDir()) / "sample_bag";
  fs::remove_all(folder);
  {
    storey::bag::BagWriter writer(folder.string());
    writer.createTopic({"/robot1/scan", "sensor_msgs/msg/LaserScan", "cdr", ""});
    writer.createTopic({"/robot1/pressure", "sensor_msgs/msg/FluidPressure", "cdr", ""});
    for (int i = 0; i < 20; ++i) {
      const std::vector<std::uint8_t> data(16 + i, static_cast<std::uint8_t>(i));
      writer.write(i % 2 ? "/robot1/scan" : "/robot1/pressure", 1000 * (20 - i), data);
    }
    writer.close();
  }
  for (const auto& entry : fs::directory_iterator(folder)) {
    if (entry.path().extension() == ".db3") {
      std::ifstream in(entry.path(), std::ios::binary);
      return std::vector<std::uint8_t>(std::istreambuf_iterator<char>(in), {});
    }
  }
  throw std::runtime_error("BagWriter wrote no .db3");
}

}  // namespace

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  storey::common::setLogLevel(storey::common::LogLevel::kSilent);
  static const std::vector<std::uint8_t> sample = sampleDb3();
  std::vector<std::uint8_t> bytes;
  if (size > 0 && (data[0] & 1)) {
    bytes = storey::fuzz::patchSample(sample, data + 1, size - 1);
  } else {
    bytes.assign(data, data + size);
  }
  const fs::path folder = fs::path(storey::fuzz::fuzzTempDir()) / "bag";
  fs::create_directories(folder);
  {
    std::ofstream out(folder / "bag_0.db3", std::ios::binary | std::ios::trunc);
    out.write(reinterpret_cast<const char*>(bytes.data()),
              static_cast<std::streamsize>(bytes.size()));
  }
  try {
    storey::bag::BagReader reader(folder.string());
    (void)reader.summary();
    storey::bag::BagMessage message;
    while (true) {
      try {
        if (!reader.next(message)) break;
      } catch (const storey::bag::BagError&) {
        break;  // documented: corrupt database named; earlier messages stay valid
      }
    }
  } catch (const std::runtime_error&) {
  }
  return 0;
}
