#include "storey/common/file_checks.h"

#include <sys/stat.h>

#include <cerrno>
#include <cstdio>
#include <cstring>
#include <stdexcept>

namespace storey::common {
namespace {

std::string kindOf(mode_t mode) {
  if (S_ISREG(mode)) return "a regular file";
  if (S_ISDIR(mode)) return "a directory";
  if (S_ISFIFO(mode)) return "a FIFO";
  if (S_ISCHR(mode)) return "a character device";
  if (S_ISBLK(mode)) return "a block device";
  if (S_ISSOCK(mode)) return "a socket";
  return "a special file";
}

struct stat statOrThrow(const std::string& path, const std::string& what) {
  struct stat st {};
  if (::stat(path.c_str(), &st) != 0) {
    const int error = errno;
    if (error == ENOENT)
      throw std::runtime_error(path + ": cannot open the " + what + ": no such file");
    throw std::runtime_error(path + ": cannot read the " + what + ": " + std::strerror(error));
  }
  return st;
}

}  // namespace

std::uint64_t requireRegularFile(const std::string& path, const std::string& what,
                                 std::uint64_t max_bytes) {
  const struct stat st = statOrThrow(path, what);
  if (!S_ISREG(st.st_mode))
    throw std::runtime_error(path + ": " + kindOf(st.st_mode) + ", not a " + what);
  const auto size = static_cast<std::uint64_t>(st.st_size);
  if (max_bytes > 0 && size > max_bytes) {
    throw std::runtime_error(path + ": " + byteCount(size) + ", more than the " +
                             byteCount(max_bytes) + " a " + what + " may have");
  }
  return size;
}

void requireDirectory(const std::string& path, const std::string& what) {
  const struct stat st = statOrThrow(path, what);
  if (!S_ISDIR(st.st_mode))
    throw std::runtime_error(path + ": " + kindOf(st.st_mode) + ", not a " + what);
}

std::string fileKind(const std::string& path) {
  struct stat st {};
  if (::stat(path.c_str(), &st) != 0) return "";
  return kindOf(st.st_mode);
}

std::string byteCount(std::uint64_t bytes) {
  char text[64];
  if (bytes < 10000)
    std::snprintf(text, sizeof text, "%llu bytes", static_cast<unsigned long long>(bytes));
  else if (bytes < 10000000)
    std::snprintf(text, sizeof text, "%.1f kB", bytes / 1e3);
  else if (bytes < 10000000000ull)
    std::snprintf(text, sizeof text, "%.1f MB", bytes / 1e6);
  else
    std::snprintf(text, sizeof text, "%.1f GB", bytes / 1e9);
  return text;
}

}  // namespace storey::common
