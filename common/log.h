// Minimal process logging to stderr: "[name] LEVEL message". Thread-safe per line.
#pragma once

#include <string>

namespace objscan {

enum class LogLevel { kDebug = 0, kInfo = 1, kWarning = 2, kError = 3 };

// Sets the prefix printed before every line (the process name) and the lowest level printed.
void SetLogName(const std::string& name);
void SetLogLevel(LogLevel level);

void Log(LogLevel level, const std::string& message);
inline void LogInfo(const std::string& message) { Log(LogLevel::kInfo, message); }
inline void LogWarning(const std::string& message) { Log(LogLevel::kWarning, message); }
inline void LogError(const std::string& message) { Log(LogLevel::kError, message); }

}  // namespace objscan
