// Minimal thread-safe logging to stderr. Components and tools share one sink.
#pragma once

#include <sstream>
#include <string>

// Fast DDS headers (including the generated message headers) define function-like macros
// logInfo/logError that would rewrite the functions below: include this header after them.
#undef logInfo
#undef logError

namespace storey::common {

enum class LogLevel { kDebug = 0, kInfo = 1, kWarn = 2, kError = 3, kSilent = 4 };

void setLogLevel(LogLevel level);
LogLevel logLevel();
void log(LogLevel level, const std::string& message);

inline void logDebug(const std::string& m) { log(LogLevel::kDebug, m); }
inline void logInfo(const std::string& m) { log(LogLevel::kInfo, m); }
inline void logWarn(const std::string& m) { log(LogLevel::kWarn, m); }
inline void logError(const std::string& m) { log(LogLevel::kError, m); }

// Builds a message from stream operands: logInfo(str("read ", n, " scans")).
template <typename... Args>
std::string str(const Args&... args) {
  std::ostringstream out;
  (out << ... << args);
  return out.str();
}

}  // namespace storey::common
