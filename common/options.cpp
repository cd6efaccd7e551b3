#include "common/options.h"

#include <cctype>
#include <cmath>

#include <cerrno>
#include <cstdio>
#include <cstdlib>
#include <fstream>
#include <sstream>

namespace objscan {
namespace {

std::string Trim(const std::string& s) {
  const auto begin = s.find_first_not_of(" \t\r\n");
  if (begin == std::string::npos) return "";
  const auto end = s.find_last_not_of(" \t\r\n");
  return s.substr(begin, end - begin + 1);
}

template <class T>
bool ParseInteger(const std::string& text, T* out) {
  if (text.empty()) return false;
  errno = 0;
  char* end = nullptr;
  const long long v = std::strtoll(text.c_str(), &end, 10);
  if (errno != 0 || *end != '\0') return false;
  *out = static_cast<T>(v);
  return static_cast<long long>(*out) == v;
}

}  // namespace

bool ParseFiniteNumber(const std::string& text, double* value) {
  if (text.empty() || std::isspace(static_cast<unsigned char>(text[0]))) return false;
  char* end = nullptr;
  const double v = std::strtod(text.c_str(), &end);
  if (*end != '\0' || !std::isfinite(v)) return false;
  *value = v;
  return true;
}

bool ParseNumberList(const std::string& text, std::vector<double>* values) {
  values->clear();
  size_t start = 0;
  while (true) {
    const size_t comma = text.find(',', start);
    std::string field = text.substr(start, comma == std::string::npos ? std::string::npos : comma - start);
    const size_t first = field.find_first_not_of(" \t"), last = field.find_last_not_of(" \t");
    field = first == std::string::npos ? std::string() : field.substr(first, last - first + 1);
    double v = 0;
    if (!ParseFiniteNumber(field, &v)) {
      values->clear();
      return false;
    }
    values->push_back(v);
    if (comma == std::string::npos) return true;
    start = comma + 1;
  }
}

OptionParser::OptionParser(std::string program, std::string description)
    : program_(std::move(program)), description_(std::move(description)) {}

void OptionParser::Add(const std::string& name, std::string* value, const std::string& help) {
  options_.push_back({name, help, false, [value](const std::string& s) { *value = s; return true; },
                      [value] { return *value; }});
}
void OptionParser::Add(const std::string& name, int* value, const std::string& help) {
  options_.push_back({name, help, false, [value](const std::string& s) { return ParseInteger(s, value); },
                      [value] { return std::to_string(*value); }});
}
void OptionParser::Add(const std::string& name, int64_t* value, const std::string& help) {
  options_.push_back({name, help, false, [value](const std::string& s) { return ParseInteger(s, value); },
                      [value] { return std::to_string(*value); }});
}
void OptionParser::Add(const std::string& name, double* value, const std::string& help) {
  options_.push_back({name, help, false,
                      [value](const std::string& s) {
                        if (s.empty()) return false;
                        errno = 0;
                        char* end = nullptr;
                        const double v = std::strtod(s.c_str(), &end);
                        if (errno != 0 || *end != '\0') return false;
                        *value = v;
                        return true;
                      },
                      [value] {
                        std::ostringstream os;
                        os << *value;
                        return os.str();
                      }});
}
void OptionParser::Add(const std::string& name, bool* value, const std::string& help) {
  options_.push_back({name, help, true,
                      [value](const std::string& s) {
                        if (s == "true" || s == "1" || s == "yes" || s == "on") *value = true;
                        else if (s == "false" || s == "0" || s == "no" || s == "off") *value = false;
                        else return false;
                        return true;
                      },
                      [value] { return std::string(*value ? "true" : "false"); }});
}

void OptionParser::AddChannel(std::string* channel, const std::string& help) {
  if (channels_.empty()) {
    Option o{"channel", "rename a channel: DEFAULT=NAME (repeatable)", false,
             [this](const std::string& s) { return RenameChannel(s); }, [] { return std::string(); }};
    o.usage = [this] {
      std::string text = "  --channel DEFAULT=NAME\n      rename a channel (repeatable); the channels and their use:\n";
      for (const Channel& c : channels_)
        text += "        " + c.default_name + (*c.channel != c.default_name ? " (now " + *c.channel + ")" : "") +
                ": " + c.help + "\n";
      return text;
    };
    o.effective = [this] {
      std::string text;
      for (const Channel& c : channels_) text += "  channel " + c.default_name + " = " + *c.channel + "\n";
      return text;
    };
    o.bad_value_hint = [this] {
      std::string list = " (DEFAULT=NAME, DEFAULT one of:";
      for (const Channel& c : channels_) list += " " + c.default_name;
      return list + ")";
    };
    options_.push_back(std::move(o));
  }
  channels_.push_back({*channel, channel, help});
}

bool OptionParser::RenameChannel(const std::string& rename) {
  const auto eq = rename.find('=');
  if (eq == std::string::npos || eq == 0) return false;
  const std::string from = rename.substr(0, eq), to = rename.substr(eq + 1);
  bool found = false;
  for (Channel& c : channels_)
    if (c.default_name == from) {
      *c.channel = to;
      found = true;
    }
  return found;
}

OptionParser::Option* OptionParser::Find(const std::string& name) {
  for (auto& o : options_)
    if (o.name == name) return &o;
  return nullptr;
}

bool OptionParser::ReadFile(const std::string& path, std::string* error) {
  std::ifstream in(path);
  if (!in) {
    *error = "cannot read options file '" + path + "'";
    return false;
  }
  std::string line;
  int line_number = 0;
  while (std::getline(in, line)) {
    ++line_number;
    const auto hash = line.find('#');
    if (hash != std::string::npos) line.resize(hash);
    line = Trim(line);
    if (line.empty()) continue;
    auto sep = line.find('=');
    if (sep == std::string::npos) sep = line.find(':');
    if (sep == std::string::npos) sep = line.find_first_of(" \t");
    const std::string name = Trim(line.substr(0, sep));
    const std::string value = sep == std::string::npos ? "true" : Trim(line.substr(sep + 1));
    Option* option = Find(name);
    if (option == nullptr) {
      *error = path + ":" + std::to_string(line_number) + ": unknown option '" + name + "'";
      return false;
    }
    if (!option->set(value)) {
      *error = path + ":" + std::to_string(line_number) + ": bad value '" + value + "' for '" + name + "'";
      if (option->bad_value_hint) *error += option->bad_value_hint();
      return false;
    }
  }
  return true;
}

bool OptionParser::ParseArgs(const std::vector<std::string>& args, std::string* error) {
  // The options file first, so that the command line overrides it.
  for (size_t i = 0; i < args.size(); ++i) {
    if (args[i] == "--options-file" && i + 1 < args.size()) {
      if (!ReadFile(args[i + 1], error)) return false;
    } else if (args[i].rfind("--options-file=", 0) == 0) {
      if (!ReadFile(args[i].substr(15), error)) return false;
    }
  }
  for (size_t i = 0; i < args.size(); ++i) {
    const std::string& arg = args[i];
    if (arg == "--help" || arg == "-h") {
      help_requested_ = true;
      continue;
    }
    if (arg.rfind("--", 0) != 0 || arg.size() == 2) {
      positional_.push_back(arg);
      continue;
    }
    std::string name = arg.substr(2);
    std::string value;
    bool has_value = false;
    const auto eq = name.find('=');
    if (eq != std::string::npos) {
      value = name.substr(eq + 1);
      name.resize(eq);
      has_value = true;
    }
    if (name == "options-file") {
      if (!has_value) ++i;
      continue;
    }
    Option* option = Find(name);
    if (option == nullptr) {
      *error = "unknown option '--" + name + "'";
      return false;
    }
    if (!has_value) {
      if (option->is_flag) {
        value = "true";
      } else if (i + 1 < args.size()) {
        value = args[++i];
      } else {
        *error = "option '--" + name + "' needs a value";
        return false;
      }
    }
    if (!option->set(value)) {
      *error = "bad value '" + value + "' for option '--" + name + "'";
      if (option->bad_value_hint) *error += option->bad_value_hint();
      return false;
    }
  }
  return true;
}

bool OptionParser::Parse(int argc, char** argv, std::string* error) {
  std::vector<std::string> args;
  for (int i = 1; i < argc; ++i) args.emplace_back(argv[i]);
  return ParseArgs(args, error);
}

std::string OptionParser::Usage() const {
  std::ostringstream os;
  os << "usage: " << program_ << " [options]\n" << description_ << "\n\noptions:\n";
  for (const auto& o : options_) {
    if (o.usage) {
      os << o.usage();
      continue;
    }
    os << "  --" << o.name << (o.is_flag ? "" : " VALUE") << "\n      " << o.help << " (default: " << o.get()
       << ")\n";
  }
  os << "  --options-file FILE\n      read 'name = value' lines first (command line wins)\n";
  return os.str();
}

std::string OptionParser::Effective() const {
  std::ostringstream os;
  os << program_ << " configuration:\n";
  for (const auto& o : options_) os << (o.effective ? o.effective() : "  " + o.name + " = " + o.get() + "\n");
  return os.str();
}

bool ParseCommandLineOrExit(OptionParser& parser, int argc, char** argv, int* exit_code, bool allow_positional) {
  std::string error;
  bool ok = parser.Parse(argc, argv, &error);
  if (ok && !allow_positional && !parser.positional().empty() && !parser.help_requested()) {
    error = "unexpected argument '" + parser.positional()[0] + "' (options start with --, e.g. --log FILE)";
    ok = false;
  }
  if (!ok) {
    std::fprintf(stderr, "error: %s\n\n%s", error.c_str(), parser.Usage().c_str());
    *exit_code = 2;
    return false;
  }
  if (parser.help_requested()) {
    std::printf("%s", parser.Usage().c_str());
    *exit_code = 0;
    return false;
  }
  return true;
}

}  // namespace objscan
