#include "storey/common/log.h"

#include <atomic>
#include <cstdlib>
#include <cstring>
#include <iostream>
#include <mutex>

namespace storey::common {
namespace {

LogLevel initialLevel() {
  const char* env = std::getenv("STOREY_LOG_LEVEL");
  if (!env) return LogLevel::kInfo;
  if (!std::strcmp(env, "debug")) return LogLevel::kDebug;
  if (!std::strcmp(env, "warn")) return LogLevel::kWarn;
  if (!std::strcmp(env, "error")) return LogLevel::kError;
  if (!std::strcmp(env, "silent")) return LogLevel::kSilent;
  return LogLevel::kInfo;
}

std::atomic<LogLevel>& level() {
  static std::atomic<LogLevel> current{initialLevel()};
  return current;
}

std::mutex& sinkMutex() {
  static std::mutex mutex;
  return mutex;
}

}  // namespace

void setLogLevel(LogLevel new_level) { level() = new_level; }
LogLevel logLevel() { return level(); }

void log(LogLevel message_level, const std::string& message) {
  if (message_level < level()) return;
  static const char* kNames[] = {"debug", "info", "warn", "error", ""};
  std::lock_guard<std::mutex> lock(sinkMutex());
  std::cerr << "[" << kNames[static_cast<int>(message_level)] << "] " << message << "\n";
}

}  // namespace storey::common
