#include "procman/config.h"

#include <signal.h>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <fstream>
#include <functional>
#include <set>
#include <sstream>

namespace objscan {
namespace {

std::string Trim(const std::string& s) {
  const size_t a = s.find_first_not_of(" \t\r");
  if (a == std::string::npos) return "";
  const size_t b = s.find_last_not_of(" \t\r");
  return s.substr(a, b - a + 1);
}

bool ValidName(const std::string& name) {
  if (name.empty() || name.size() > 64) return false;
  return std::all_of(name.begin(), name.end(), [](char c) {
    return (c >= 'a' && c <= 'z') || (c >= 'A' && c <= 'Z') || (c >= '0' && c <= '9') || c == '_' || c == '-' ||
           c == '.';
  });
}

// Replaces ${NAME}; false with *missing set to the first undefined name (or "${" when unterminated).
bool Substitute(const std::string& in, const std::map<std::string, std::string>& vars, std::string* out,
                std::string* missing) {
  out->clear();
  for (size_t i = 0; i < in.size(); ++i) {
    if (in[i] == '$' && i + 1 < in.size() && in[i + 1] == '{') {
      const size_t end = in.find('}', i + 2);
      if (end == std::string::npos) {
        *missing = "${ without }";
        return false;
      }
      const std::string name = in.substr(i + 2, end - i - 2);
      auto it = vars.find(name);
      if (it == vars.end()) {
        *missing = name;
        return false;
      }
      *out += it->second;
      i = end;
    } else {
      *out += in[i];
    }
  }
  return true;
}

}  // namespace

const ProcmanEntry* ProcmanConfig::Find(const std::string& name) const {
  for (const auto& e : entries)
    if (e.name == name) return &e;
  return nullptr;
}

std::vector<std::string> ProcmanConfig::Hosts() const {
  std::vector<std::string> hosts;
  for (const auto& e : entries)
    if (std::find(hosts.begin(), hosts.end(), e.host) == hosts.end()) hosts.push_back(e.host);
  return hosts;
}

std::vector<std::string> ProcmanConfig::Groups() const {
  std::vector<std::string> groups;
  for (const auto& e : entries)
    if (std::find(groups.begin(), groups.end(), e.group) == groups.end()) groups.push_back(e.group);
  return groups;
}

std::string ConfigHash(const std::string& text) {
  uint64_t h = 1469598103934665603ull;
  for (unsigned char c : text) {
    h ^= c;
    h *= 1099511628211ull;
  }
  char buffer[17];
  std::snprintf(buffer, sizeof(buffer), "%016llx", static_cast<unsigned long long>(h));
  return buffer;
}

bool SplitWords(const std::string& line, std::vector<std::string>* words, std::string* error) {
  words->clear();
  std::string word;
  char quote = 0;
  bool in_word = false;
  for (char ch : line) {
    if (quote) {
      if (ch == quote)
        quote = 0;
      else
        word += ch;
    } else if (ch == '\'' || ch == '"') {
      quote = ch;
      in_word = true;
    } else if (ch == '#' && !in_word) {
      break;
    } else if (ch == ' ' || ch == '\t' || ch == '\r') {
      if (in_word) words->push_back(word);
      word.clear();
      in_word = false;
    } else {
      word += ch;
      in_word = true;
    }
  }
  if (quote) {
    *error = "unterminated quote";
    return false;
  }
  if (in_word) words->push_back(word);
  return true;
}

int StopSignalNumber(const std::string& name) {
  static const std::pair<const char*, int> kSignals[] = {{"SIGINT", SIGINT},   {"SIGTERM", SIGTERM},
                                                          {"SIGHUP", SIGHUP},   {"SIGQUIT", SIGQUIT},
                                                          {"SIGUSR1", SIGUSR1}, {"SIGUSR2", SIGUSR2},
                                                          {"SIGKILL", SIGKILL}};
  for (const auto& s : kSignals)
    if (name == s.first) return s.second;
  return -1;
}

bool ParseProcmanConfig(const std::string& text, const std::string& source, ProcmanConfig* config,
                        std::string* error) {
  *config = ProcmanConfig();
  config->hash = ConfigHash(text);
  std::istringstream in(text);
  std::string line, group;
  int number = 0;
  ProcmanEntry* entry = nullptr;
  auto fail = [&](int at, const std::string& what) {
    *error = source + ":" + std::to_string(at) + ": " + what;
    return false;
  };
  auto finish = [&]() {
    if (!entry) return true;
    if (entry->host.empty()) return fail(entry->line, "process " + entry->name + " has no 'host = ...'");
    if (entry->command.empty()) return fail(entry->line, "process " + entry->name + " has no 'command = ...'");
    return true;
  };
  while (std::getline(in, line)) {
    ++number;
    std::vector<std::string> words;
    std::string split_error;
    if (!SplitWords(line, &words, &split_error)) return fail(number, split_error);
    if (words.empty()) continue;
    const size_t eq = line.find('=');
    const std::string first = words[0];
    if ((first == "group" || first == "process") && (eq == std::string::npos || words.size() == 2)) {
      if (words.size() != 2 || !ValidName(words[1]))
        return fail(number, "expected '" + first + " NAME' (letters, digits, _ - .)");
      if (!finish()) return false;
      entry = nullptr;
      if (first == "group") {
        group = words[1];
        continue;
      }
      if (config->Find(words[1])) return fail(number, "process " + words[1] + " is defined twice");
      config->entries.emplace_back();
      entry = &config->entries.back();
      entry->name = words[1];
      entry->group = group;
      entry->line = number;
      continue;
    }
    if (eq == std::string::npos) return fail(number, "expected 'group NAME', 'process NAME' or 'KEY = VALUE'");
    if (!entry) return fail(number, "'" + Trim(line.substr(0, eq)) + " = ...' outside a process");
    const std::string key = Trim(line.substr(0, eq));
    // command keeps its text (split after ${VAR} substitution), after is a list, every other key takes one word
    // (quote a value that holds spaces).
    const std::string raw = Trim(line.substr(eq + 1));
    std::vector<std::string> value_words;
    if (!SplitWords(raw, &value_words, &split_error)) return fail(number, split_error);
    if (value_words.empty()) return fail(number, key + " has no value");
    const bool list = key == "command" || key == "after";
    if (!list && value_words.size() != 1)
      return fail(number, key + " takes one value (quote it if it holds spaces), got '" + raw + "'");
    const std::string value = list ? raw : value_words[0];
    if (key == "host") {
      if (!ValidName(value)) return fail(number, "host must be one word (letters, digits, _ - .), got '" + value + "'");
      entry->host = value;
    } else if (key == "command") {
      entry->command = value;
    } else if (key == "cwd") {
      entry->cwd = value;
    } else if (key == "env") {
      const size_t e = value.find('=');
      if (e == std::string::npos || e == 0 || value.find_first_of(" \t") < e)
        return fail(number, "env must be KEY=VALUE, got '" + value + "'");
      entry->env.push_back(value);
    } else if (key == "respawn") {
      if (value != "true" && value != "false") return fail(number, "respawn must be true or false, got '" + value + "'");
      entry->respawn = value == "true";
    } else if (key == "stop_signal") {
      const int s = StopSignalNumber(value);
      if (s < 0)
        return fail(number, "stop_signal must be SIGINT, SIGTERM, SIGHUP, SIGQUIT, SIGUSR1, SIGUSR2 or SIGKILL, got '" +
                                value + "'");
      entry->stop_signal = s;
    } else if (key == "grace_s") {
      char* end = nullptr;
      const double g = std::strtod(value.c_str(), &end);
      if (end == value.c_str() || *end != '\0' || !std::isfinite(g) || g < 0.1 || g > 600)
        return fail(number, "grace_s must be a number of seconds from 0.1 to 600, got '" + value + "'");
      entry->grace_s = g;
    } else if (key == "after") {
      for (const auto& n : value_words) {
        if (!ValidName(n)) return fail(number, "after: '" + n + "' is not a process name");
        entry->after.push_back(n);
      }
    } else {
      return fail(number, "unknown key '" + key + "' (host, command, cwd, env, respawn, stop_signal, grace_s, after)");
    }
  }
  if (!finish()) return false;
  if (config->entries.empty()) return fail(number, "no process defined");
  for (const auto& e : config->entries)
    for (const auto& a : e.after) {
      if (!config->Find(a)) return fail(e.line, "process " + e.name + ": after names unknown process '" + a + "'");
      if (a == e.name) return fail(e.line, "process " + e.name + " cannot start after itself");
    }
  // Cycles in 'after' would make the sheriff wait forever.
  std::map<std::string, int> mark;  // 0 unvisited, 1 on the path, 2 done
  std::function<bool(const ProcmanEntry&)> visit = [&](const ProcmanEntry& e) {
    mark[e.name] = 1;
    for (const auto& a : e.after) {
      if (mark[a] == 1) return fail(e.line, "process " + e.name + ": 'after' forms a cycle through " + a);
      if (mark[a] == 0 && !visit(*config->Find(a))) return false;
    }
    mark[e.name] = 2;
    return true;
  };
  for (const auto& e : config->entries)
    if (mark[e.name] == 0 && !visit(e)) return false;
  return true;
}

bool ReadProcmanConfig(const std::string& path, ProcmanConfig* config, std::string* error) {
  std::ifstream in(path, std::ios::binary);
  if (!in) {
    *error = "cannot read procman config " + path;
    return false;
  }
  std::stringstream buffer;
  buffer << in.rdbuf();
  return ParseProcmanConfig(buffer.str(), path, config, error);
}

bool ResolveCommand(const ProcmanEntry& entry, const std::map<std::string, std::string>& vars,
                    ResolvedCommand* resolved, std::string* error) {
  *resolved = ResolvedCommand();
  std::string missing, text;
  auto undefined = [&](const std::string& field) {
    *error = "process " + entry.name + " (line " + std::to_string(entry.line) + "): " + field + " uses ${" + missing +
             "}, which this deputy was not given (add " + missing + "=... to its command line)";
    if (missing.rfind("${", 0) == 0)
      *error = "process " + entry.name + " (line " + std::to_string(entry.line) + "): " + field + ": " + missing;
    return false;
  };
  if (!Substitute(entry.command, vars, &text, &missing)) return undefined("command");
  std::string split_error;
  if (!SplitWords(text, &resolved->argv, &split_error)) {
    *error = "process " + entry.name + ": command: " + split_error;
    return false;
  }
  if (resolved->argv.empty()) {
    *error = "process " + entry.name + ": the command is empty";
    return false;
  }
  if (!Substitute(entry.cwd, vars, &resolved->cwd, &missing)) return undefined("cwd");
  for (const auto& e : entry.env) {
    if (!Substitute(e, vars, &text, &missing)) return undefined("env");
    resolved->env.push_back(text);
  }
  return true;
}

}  // namespace objscan
