// The procman configuration (LCM-free): which processes make up a system, the host each runs on, and how each is
// started and stopped. One file is read by the sheriff (what to order) and by every deputy (what it may run): a
// deputy runs only commands from the file it was started with, and orders carry the file's hash.
//
// Format (line-based; '#' starts a comment outside quotes; blank lines ignored):
//   group NAME                   processes below belong to group NAME (until the next group line)
//   process NAME                 starts an entry; the key lines below (indentation optional) describe it
//     host = HOST                required: the deputy's host name that runs it
//     command = PROGRAM ARGS...  required: split on whitespace, '...' or "..." quote (no shell)
//     cwd = DIR                  working directory (default: the deputy's)
//     env = KEY=VALUE            one environment variable per line, repeatable
//     respawn = true|false       restart it when it dies by a signal or a non-zero exit (default false)
//     stop_signal = SIGINT       the signal that asks it to stop: SIGINT, SIGTERM, SIGHUP, SIGQUIT, SIGUSR1,
//                                SIGUSR2 or SIGKILL (default SIGINT)
//     grace_s = 5                s between the stop signal and SIGKILL (0.1 to 600, default 5)
//     after = NAME...            start only once these have published PROCESS_STATUS since their start (the
//                                sheriff waits; name only objscan processes: lcm-logger publishes none)
// ${NAME} in command, cwd and env is replaced when the entry is resolved on its host (ResolveCommand) by the
// variables that host's deputy was given as KEY=VALUE (e.g. ${BIN}, ${LCM_URL}, ${OUT}): paths may differ per host, the file and
// its hash do not.
#pragma once

#include <cstdint>
#include <map>
#include <string>
#include <vector>

namespace objscan {

struct ProcmanEntry {
  std::string name;
  std::string group;
  std::string host;
  std::string command;            // unresolved (may hold ${VAR})
  std::string cwd;                // unresolved; "" = the deputy's working directory
  std::vector<std::string> env;   // unresolved KEY=VALUE
  bool respawn = false;
  int stop_signal = 2;            // SIGINT
  double grace_s = 5.0;           // s
  std::vector<std::string> after; // entry names
  int line = 0;                   // line of its 'process' line in the file
};

struct ProcmanConfig {
  std::vector<ProcmanEntry> entries;  // in file order
  std::string hash;                   // ConfigHash of the file's text
  const ProcmanEntry* Find(const std::string& name) const;
  std::vector<std::string> Hosts() const;   // distinct hosts, in file order
  std::vector<std::string> Groups() const;  // distinct groups, in file order ("" for entries before any group)
};

// 16 hex digits: FNV-1a 64 of the text. Sheriff and deputies compare it to know they read the same file.
std::string ConfigHash(const std::string& text);

// Splits a line into words: whitespace separates, '...' or "..." quote, '#' outside a word starts a comment.
// False with *error on an unterminated quote.
bool SplitWords(const std::string& line, std::vector<std::string>* words, std::string* error);

// Parses and validates a config. False with *error "line N: ..." on an unknown key or line, a missing host or
// command, a duplicate name, a bad signal, grace or respawn value, an 'after' naming an unknown entry or forming a
// cycle, or a file without entries. `source` names the file in the messages.
bool ParseProcmanConfig(const std::string& text, const std::string& source, ProcmanConfig* config,
                        std::string* error);
bool ReadProcmanConfig(const std::string& path, ProcmanConfig* config, std::string* error);

// The entry's command, working directory and environment with ${VAR} replaced from vars. False with *error naming
// the entry, its line and the variable when one is undefined, or when the command is empty after splitting.
struct ResolvedCommand {
  std::vector<std::string> argv;
  std::string cwd;
  std::vector<std::string> env;  // KEY=VALUE, added to the deputy's environment
};
bool ResolveCommand(const ProcmanEntry& entry, const std::map<std::string, std::string>& vars,
                    ResolvedCommand* resolved, std::string* error);

// "SIGINT" -> 2 etc. for the signals a config may name; -1 otherwise.
int StopSignalNumber(const std::string& name);

}  // namespace objscan
