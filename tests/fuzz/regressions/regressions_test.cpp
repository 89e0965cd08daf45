// Replays every kept fuzz input (tests/fuzz/regressions/<target>/ — inputs that once
// crashed — and the seed corpus tests/fuzz/corpus/<target>/) through the fuzz targets'
// entry points: each must be handled with a clean error or accepted, never a crash or
// an escaping exception of another kind.
#include <gtest/gtest.h>

#include <cstdint>
#include <filesystem>
#include <fstream>
#include <iterator>
#include <string>
#include <vector>

#define STOREY_FUZZ_ENTRY(name) \
  extern "C" int storeyFuzz_##name(const std::uint8_t* data, std::size_t size);
STOREY_FUZZ_ENTRY(carmen)
STOREY_FUZZ_ENTRY(graph)
STOREY_FUZZ_ENTRY(scenario)
STOREY_FUZZ_ENTRY(config)
STOREY_FUZZ_ENTRY(bag)
STOREY_FUZZ_ENTRY(journal)
STOREY_FUZZ_ENTRY(journal_file)
STOREY_FUZZ_ENTRY(cdr)

namespace fs = std::filesystem;

namespace {

using Entry = int (*)(const std::uint8_t*, std::size_t);

// Runs every file of regressions/<target> and corpus/<target>; returns how many.
std::size_t replay(const std::string& target, Entry entry) {
  std::size_t count = 0;
  for (const char* kind : {"regressions", "corpus"}) {
    const fs::path folder = fs::path(STOREY_SOURCE_DIR) / "tests/fuzz" / kind / target;
    if (!fs::is_directory(folder)) continue;
    for (const auto& file : fs::directory_iterator(folder)) {
      if (!file.is_regular_file()) continue;
      std::ifstream in(file.path(), std::ios::binary);
      const std::vector<std::uint8_t> bytes{std::istreambuf_iterator<char>(in), {}};
      SCOPED_TRACE(file.path().string());
      EXPECT_NO_THROW(entry(bytes.data(), bytes.size()));
      ++count;
    }
  }
  // Edge cases every target must take: nothing, and one byte of each parity.
  const std::uint8_t odd = 1, even = 0;
  EXPECT_NO_THROW(entry(nullptr, 0));
  EXPECT_NO_THROW(entry(&odd, 1));
  EXPECT_NO_THROW(entry(&even, 1));
  return count;
}

}  // namespace

TEST(FuzzRegressions, Carmen) { EXPECT_GT(replay("carmen", storeyFuzz_carmen), 0u); }
TEST(FuzzRegressions, Graph) { EXPECT_GT(replay("graph", storeyFuzz_graph), 0u); }
TEST(FuzzRegressions, Scenario) { EXPECT_GT(replay("scenario", storeyFuzz_scenario), 0u); }
TEST(FuzzRegressions, Config) { EXPECT_GT(replay("config", storeyFuzz_config), 0u); }
TEST(FuzzRegressions, Bag) { replay("bag", storeyFuzz_bag); }
TEST(FuzzRegressions, Journal) { replay("journal", storeyFuzz_journal); }
TEST(FuzzRegressions, JournalFile) { replay("journal_file", storeyFuzz_journal_file); }
TEST(FuzzRegressions, Cdr) { replay("cdr", storeyFuzz_cdr); }
