// One child OS process of a session: started with fork/exec in its own process group, stdout and stderr appended to
// a log file, polled without blocking, stopped with SIGINT then SIGTERM then SIGKILL. A child gets SIGTERM when
// the process that started it dies (PR_SET_PDEATHSIG), so none outlives its session.
#pragma once

#include <sys/types.h>

#include <cstdint>
#include <string>
#include <vector>

namespace objscan {

// "SIGKILL" for 9 ("signal N" when unknown).
std::string SignalName(int signal);

class ChildProcess {
 public:
  ChildProcess(std::string name, std::vector<std::string> argv, std::string log_path);
  ~ChildProcess();  // kills the process group if still running
  ChildProcess(const ChildProcess&) = delete;
  ChildProcess& operator=(const ChildProcess&) = delete;

  // Before Start: the working directory ("" = this process's) and KEY=VALUE variables added to the environment.
  void SetWorkingDirectory(std::string dir) { cwd_ = std::move(dir); }
  void SetEnvironment(std::vector<std::string> env) { env_ = std::move(env); }
  // Starts the process. Returns false with *error when it cannot be started (fork failure, or the executable does
  // not exist / is not executable: checked before fork so the error is clear).
  bool Start(std::string* error);
  // Non-blocking: true while running. After exit, exit_code() holds the code (128 + signal when killed).
  bool Running();
  // Sends `signal` to the process group, waits up to timeout_ms for it to exit. Returns true once exited.
  bool StopWith(int signal, int timeout_ms);
  // Sends `signal` to the process group without waiting. False when it is not running.
  bool Signal(int signal);
  // SIGINT, then SIGTERM, then SIGKILL, each with the grace period.
  void Stop(int grace_ms);

  const std::string& name() const { return name_; }
  const std::string& log_path() const { return log_path_; }
  pid_t pid() const { return pid_; }
  bool started() const { return pid_ > 0; }
  int exit_code() const { return exit_code_; }
  // After exit: the process's peak resident memory (kB; 0 before it exited).
  int64_t peak_rss_kb() const { return peak_rss_kb_; }
  // After exit: "exited with code N" or "was killed by signal 9 (SIGKILL)".
  std::string DescribeExit() const;
  std::string CommandLine() const;
  // The last lines of the log file (for error messages).
  std::string LogTail(int lines) const;

 private:
  std::string name_;
  std::vector<std::string> argv_;
  std::string log_path_;
  std::string cwd_;
  std::vector<std::string> env_;
  pid_t pid_ = -1;
  bool exited_ = false;
  int exit_code_ = -1;
  int term_signal_ = 0;  // the signal that ended it, 0 when it exited
  int64_t peak_rss_kb_ = 0;
};

}  // namespace objscan
