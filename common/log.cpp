#include "common/log.h"

#include <cstdio>
#include <mutex>

namespace objscan {
namespace {
std::mutex g_mutex;
std::string g_name = "objscan";
LogLevel g_level = LogLevel::kInfo;
const char* LevelName(LogLevel level) {
  switch (level) {
    case LogLevel::kDebug: return "DEBUG";
    case LogLevel::kInfo: return "INFO";
    case LogLevel::kWarning: return "WARN";
    case LogLevel::kError: return "ERROR";
  }
  return "?";
}
}  // namespace

void SetLogName(const std::string& name) {
  std::lock_guard<std::mutex> lock(g_mutex);
  g_name = name;
}
void SetLogLevel(LogLevel level) {
  std::lock_guard<std::mutex> lock(g_mutex);
  g_level = level;
}
void Log(LogLevel level, const std::string& message) {
  std::lock_guard<std::mutex> lock(g_mutex);
  if (level < g_level) return;
  std::fprintf(stderr, "[%s] %s %s\n", g_name.c_str(), LevelName(level), message.c_str());
  std::fflush(stderr);
}

}  // namespace objscan
