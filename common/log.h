// Minimal process logging to stderr: "[name] LEVEL message". Thread-safe per line.
#pragma once

#include <map>
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

// Warnings about hostile or repeated input, each distinct text at most once per period_s (now_s: the caller's clock).
class WarningLimiter {
 public:
  explicit WarningLimiter(double period_s = 10.0) : period_s_(period_s) {}
  // Logs the warning unless the same text was logged less than period_s ago; true when logged.
  bool Warn(const std::string& text, double now_s) {
    auto it = last_s_.find(text);
    if (it != last_s_.end() && now_s - it->second < period_s_) return false;
    if (last_s_.size() > 1000) last_s_.clear();  // forged texts must not grow it without bound
    last_s_[text] = now_s;
    LogWarning(text);
    return true;
  }

 private:
  double period_s_;
  std::map<std::string, double> last_s_;
};

}  // namespace objscan
