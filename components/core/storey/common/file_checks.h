// Checks made before an input file is opened. A FIFO would block its reader forever, a
// device such as /dev/zero never ends, and a directory gives a reader's error that names
// neither the path nor what was expected; all are refused by name. Errors are
// std::runtime_error: "/dev/zero: a character device, not a journal".
#pragma once

#include <cstdint>
#include <string>

namespace storey::common {

// The path exists and is a regular file (symbolic links followed). `what` names what
// the file should be ("journal", "CARMEN log"). Returns its size in bytes; a `max_bytes`
// above 0 bounds it, and the error names the limit.
std::uint64_t requireRegularFile(const std::string& path, const std::string& what,
                                 std::uint64_t max_bytes = 0);

// The path exists and is a directory.
void requireDirectory(const std::string& path, const std::string& what);

// "a directory", "a FIFO", "a character device", ... for what `path` is ("" when it does
// not exist).
std::string fileKind(const std::string& path);

// Bytes as "3.9 MB" or "512 bytes", for messages.
std::string byteCount(std::uint64_t bytes);

}  // namespace storey::common
