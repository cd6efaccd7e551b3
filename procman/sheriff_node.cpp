#include "procman/sheriff_node.h"

#include <poll.h>
#include <unistd.h>

#include <cstdio>

#include "common/log.h"
#include "common/time.h"
#include "objscan/process_status_t.hpp"
#include "objscan/procman_output_t.hpp"
#include "procman/deputy_node.h"
#include "procman/procman_messages.h"

namespace objscan {

SheriffNode::SheriffNode(Bus& bus, ProcmanConfig config, SheriffOptions sheriff_options, SheriffNodeOptions options)
    : bus_(bus), sheriff_(std::move(config), std::move(sheriff_options)), options_(std::move(options)) {
  start_s_ = MonotonicSeconds();
  bus_.SubscribeMessage<procman_deputy_t>(
      kProcmanDeputyChannel,
      [this](const procman_deputy_t& msg, const RawMessage&) {
        DeputyReport report;
        std::string why;
        if (!DeputyReportFromMessage(msg, &report, &why)) {
          ++malformed_;
          Warn("malformed deputy report ignored: " + why);
          return;
        }
        sheriff_.OnDeputyReport(report, MonotonicSeconds());
      },
      [this](const RawMessage& raw) {
        ++malformed_;
        Warn("malformed deputy report ignored (" + std::to_string(raw.size) + " bytes): " + raw.why);
      });
  bus_.SubscribeMessage<process_status_t>(
      "PROCESS_STATUS",
      [this](const process_status_t& msg, const RawMessage&) { sheriff_.OnProcessStatus(msg.name, MonotonicSeconds()); },
      [this](const RawMessage& raw) {
        ++malformed_;
        Warn("malformed PROCESS_STATUS ignored: " + raw.why);
      });
  bus_.SubscribeMessage<procman_output_t>(
      kProcmanOutputChannel, [](const procman_output_t& msg, const RawMessage&) {
        std::string text = msg.text;
        // Prefix each line with its process (output may end mid-line).
        std::string out;
        bool line_start = true;
        for (char c : text) {
          if (line_start) out += "[" + msg.host + "/" + msg.name + "] ";
          out += c;
          line_start = c == '\n';
        }
        std::fputs(out.c_str(), stdout);
        std::fflush(stdout);
      });
}

void SheriffNode::Warn(const std::string& why) { warnings_.Warn(why, MonotonicSeconds()); }

bool SheriffNode::Command(const std::string& line, std::string* error) {
  std::vector<SheriffStep> steps;
  if (line.find_first_not_of(" \t") == std::string::npos) return true;
  if (line == "unfollow") return sheriff_.Follow("", error);
  if (!ParseSheriffScript(line, &steps, error)) return false;
  const double now = MonotonicSeconds();
  for (const auto& s : steps) {
    bool ok = true;
    if (s.verb == "start") ok = sheriff_.Start(s.target, now, error);
    else if (s.verb == "stop") ok = sheriff_.Stop(s.target, now, error);
    else if (s.verb == "restart") ok = sheriff_.Restart(s.target, now, error);
    else if (s.verb == "follow") ok = sheriff_.Follow(s.target, error);
    else {
      *error = "'" + s.verb + "' is a script step; type start, stop, restart, follow or unfollow";
      ok = false;
    }
    if (!ok) return false;
  }
  next_orders_s_ = 0;  // send now
  return true;
}

void SheriffNode::SendOrders(int64_t wall_utime) {
  if (options_.observe) return;
  for (const auto& o : sheriff_.Orders(MonotonicSeconds()))
    bus_.PublishMessage(kProcmanOrdersChannel, OrdersToMessage(o, wall_utime, orders_seq_++));
}

void SheriffNode::RunScript(double now_s) {
  while (step_ < options_.script.size()) {
    const SheriffStep& s = options_.script[step_];
    if (step_started_s_ < 0) {
      step_started_s_ = now_s;
      LogInfo("script: " + s.text);
    }
    std::string error;
    bool done = true;
    if (s.verb == "start" || s.verb == "stop" || s.verb == "restart" || s.verb == "follow") {
      if (!Command(s.verb + " " + s.target, &error)) {
        LogError("script step '" + s.text + "': " + error);
        script_failed_ = finished_ = true;
        return;
      }
    } else if (s.verb == "sleep") {
      done = now_s - step_started_s_ >= s.seconds;
    } else {
      if (!sheriff_.Names(s.target)) {
        LogError("script step '" + s.text + "': '" + s.target + "' is neither a process nor a group of the config");
        script_failed_ = finished_ = true;
        return;
      }
      done = s.verb == "wait-running" ? sheriff_.Running(s.target)
             : s.verb == "wait-status" ? sheriff_.StatusSeen(s.target)
                                       : sheriff_.Ended(s.target);
      if (!done && now_s - step_started_s_ > s.seconds) {
        LogError("script step '" + s.text + "' timed out after " + std::to_string(s.seconds).substr(0, 5) +
                 " s; the state:\n" + FormatSheriffView(sheriff_, now_s));
        script_failed_ = finished_ = true;
        return;
      }
    }
    if (!done) return;
    ++step_;
    step_started_s_ = -1;
  }
  LogInfo("script done");
  finished_ = true;
}

void SheriffNode::ReadCommands() {
  struct pollfd p {STDIN_FILENO, POLLIN, 0};
  while (poll(&p, 1, 0) > 0 && (p.revents & (POLLIN | POLLHUP))) {
    char buffer[256];
    const ssize_t n = read(STDIN_FILENO, buffer, sizeof(buffer));
    if (n <= 0) {  // end of input: no more commands
      options_.commands_from_stdin = false;
      return;
    }
    typed_.append(buffer, static_cast<size_t>(n));
    if (typed_.size() > 4096) typed_.clear();  // not a person typing
  }
  size_t eol;
  while ((eol = typed_.find('\n')) != std::string::npos) {
    const std::string line = typed_.substr(0, eol);
    typed_.erase(0, eol + 1);
    if (line == "quit" || line == "exit") {
      finished_ = true;
      return;
    }
    std::string error;
    if (!Command(line, &error)) std::printf("%s\n", error.c_str());
  }
}

void SheriffNode::Tick(int64_t wall_utime) {
  const double now = MonotonicSeconds();
  if (options_.commands_from_stdin) ReadCommands();
  if (!options_.script.empty() && !finished_) RunScript(now);
  if (now >= next_orders_s_) {
    SendOrders(wall_utime);
    next_orders_s_ = now + 1.0;
  }
  if (options_.status_once_after_s >= 0 && now - start_s_ >= options_.status_once_after_s && !finished_) {
    std::fputs(FormatSheriffView(sheriff_, now).c_str(), stdout);
    std::fflush(stdout);
    finished_ = true;
  }
  if ((options_.view || options_.status_lines) && now >= next_view_s_) {
    next_view_s_ = now + 1.0;
    const std::string view = FormatSheriffView(sheriff_, now);
    if (options_.view)
      std::printf("\033[H\033[2J%s\ncommands: start|stop|restart TARGET, follow NAME, unfollow, quit\n> ", view.c_str());
    else
      std::printf("%s\n", view.c_str());
    std::fflush(stdout);
  }
}

}  // namespace objscan
