#include "procman/child_process.h"

#include <fcntl.h>
#include <signal.h>
#include <string.h>
#include <sys/prctl.h>
#include <sys/resource.h>
#include <sys/time.h>
#include <sys/stat.h>
#include <sys/wait.h>
#include <unistd.h>

#include <algorithm>
#include <chrono>
#include <deque>
#include <fstream>
#include <thread>

namespace objscan {
namespace {
bool IsExecutable(const std::string& file) {
  if (file.find('/') != std::string::npos) return access(file.c_str(), X_OK) == 0;
  const char* path = getenv("PATH");
  std::string dirs = path ? path : "/usr/bin:/bin";
  size_t start = 0;
  while (start <= dirs.size()) {
    const size_t end = dirs.find(':', start);
    const std::string dir = dirs.substr(start, end == std::string::npos ? std::string::npos : end - start);
    if (!dir.empty() && access((dir + "/" + file).c_str(), X_OK) == 0) return true;
    if (end == std::string::npos) break;
    start = end + 1;
  }
  return false;
}
}  // namespace

ChildProcess::ChildProcess(std::string name, std::vector<std::string> argv, std::string log_path)
    : name_(std::move(name)), argv_(std::move(argv)), log_path_(std::move(log_path)) {}

ChildProcess::~ChildProcess() {
  if (pid_ > 0 && !exited_) {
    kill(-pid_, SIGKILL);
    waitpid(pid_, nullptr, 0);
  }
}

std::string ChildProcess::CommandLine() const {
  std::string out;
  for (const auto& a : argv_) out += (out.empty() ? "" : " ") + a;
  return out;
}

bool ChildProcess::Start(std::string* error) {
  if (argv_.empty()) {
    *error = name_ + ": empty command";
    return false;
  }
  if (!IsExecutable(argv_[0])) {
    *error = name_ + ": '" + argv_[0] + "' is not an executable file (is the project built?)";
    return false;
  }
  const int log_fd = open(log_path_.c_str(), O_WRONLY | O_CREAT | O_APPEND | O_CLOEXEC, 0644);
  if (log_fd < 0) {
    *error = name_ + ": cannot open log file " + log_path_;
    return false;
  }
  std::vector<char*> args;
  for (auto& a : argv_) args.push_back(const_cast<char*>(a.c_str()));
  args.push_back(nullptr);
  // The environment is built before fork (no allocation in the child): ours, with env_'s keys replaced or added.
  std::vector<std::string> environment;
  for (char** e = environ; e != nullptr && *e != nullptr; ++e) {
    const std::string entry(*e);
    const std::string key = entry.substr(0, entry.find('='));
    const bool replaced = std::any_of(env_.begin(), env_.end(),
                                      [&](const std::string& v) { return v.compare(0, key.size() + 1, key + "=") == 0; });
    if (!replaced) environment.push_back(entry);
  }
  environment.insert(environment.end(), env_.begin(), env_.end());
  std::vector<char*> envp;
  for (auto& e : environment) envp.push_back(const_cast<char*>(e.c_str()));
  envp.push_back(nullptr);
  const char* cwd = cwd_.empty() ? nullptr : cwd_.c_str();
  if (cwd != nullptr && access(cwd, X_OK) != 0) {
    close(log_fd);
    *error = name_ + ": the working directory " + cwd_ + " does not exist or cannot be entered";
    return false;
  }
  const pid_t parent = getpid();
  const pid_t pid = fork();
  if (pid < 0) {
    close(log_fd);
    *error = name_ + ": fork failed";
    return false;
  }
  if (pid == 0) {
    setpgid(0, 0);
    // The child stops (SIGTERM: its ordered stop) when the session dies, even by SIGKILL; no orphan keeps running.
    prctl(PR_SET_PDEATHSIG, SIGTERM);
    if (getppid() != parent) _exit(126);  // the session died before prctl took effect
    dup2(log_fd, STDOUT_FILENO);
    dup2(log_fd, STDERR_FILENO);
    const int devnull = open("/dev/null", O_RDONLY);
    if (devnull >= 0) dup2(devnull, STDIN_FILENO);
    signal(SIGINT, SIG_DFL);
    signal(SIGTERM, SIG_DFL);
    if (cwd != nullptr && chdir(cwd) != 0) {
      dprintf(STDERR_FILENO, "%s: cannot change to the working directory %s\n", name_.c_str(), cwd);
      _exit(126);
    }
    execvpe(args[0], args.data(), envp.data());
    _exit(127);
  }
  setpgid(pid, pid);
  close(log_fd);
  pid_ = pid;
  exited_ = false;
  return true;
}

bool ChildProcess::Running() {
  if (pid_ <= 0 || exited_) return false;
  int status = 0;
  struct rusage usage {};
  const pid_t r = wait4(pid_, &status, WNOHANG, &usage);
  if (r == 0) return true;
  exited_ = true;
  if (r == pid_) {
    exit_code_ = WIFEXITED(status) ? WEXITSTATUS(status) : 128 + (WIFSIGNALED(status) ? WTERMSIG(status) : 0);
    term_signal_ = WIFSIGNALED(status) ? WTERMSIG(status) : 0;
    peak_rss_kb_ = usage.ru_maxrss;  // Linux: kB, the largest of the process and its waited-for children
  }
  return false;
}

std::string SignalName(int signal) {
  const char* name = sigabbrev_np(signal);
  return name ? std::string("SIG") + name : "signal " + std::to_string(signal);
}

std::string ChildProcess::DescribeExit() const {
  if (term_signal_ != 0)
    return "was killed by signal " + std::to_string(term_signal_) + " (" + SignalName(term_signal_) + ")";
  return "exited with code " + std::to_string(exit_code_);
}

bool ChildProcess::Signal(int sig) {
  if (!Running()) return false;
  return kill(-pid_, sig) == 0;
}

bool ChildProcess::StopWith(int sig, int timeout_ms) {
  if (!Running()) return true;
  kill(-pid_, sig);
  const auto deadline = std::chrono::steady_clock::now() + std::chrono::milliseconds(timeout_ms);
  while (std::chrono::steady_clock::now() < deadline) {
    if (!Running()) return true;
    std::this_thread::sleep_for(std::chrono::milliseconds(10));
  }
  return !Running();
}

void ChildProcess::Stop(int grace_ms) {
  if (StopWith(SIGINT, grace_ms)) return;
  if (StopWith(SIGTERM, grace_ms)) return;
  StopWith(SIGKILL, grace_ms);
}

std::string ChildProcess::LogTail(int lines) const {
  std::ifstream in(log_path_);
  std::deque<std::string> tail;
  std::string line;
  while (std::getline(in, line)) {
    tail.push_back(line);
    if (static_cast<int>(tail.size()) > lines) tail.pop_front();
  }
  std::string out;
  for (const auto& l : tail) out += "    " + l + "\n";
  return out;
}

}  // namespace objscan
