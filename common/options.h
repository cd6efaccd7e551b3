// Command-line options: "--name value" or "--name=value", bool flags as "--name" / "--name=false", channels
// renamed by "--channel DEFAULT=NAME",
// "--options-file FILE" reads "name = value" lines (# comments) first; the command line overrides the file.
// Every option has a one-line help text; Usage() lists them, Effective() prints the values in force.
#pragma once

#include <cstdint>
#include <functional>
#include <string>
#include <vector>

namespace objscan {

// A whole, finite number: strtod consumed every character ("2mm", "abc", "", "nan", "inf" are refused instead of
// read as 2, 0 or NaN). For positional arguments of the tools; options go through OptionParser.
bool ParseFiniteNumber(const std::string& text, double* value);
// "a,b,c" (at least one field): every field, blanks around it ignored ("-100, -100, 0"), a ParseFiniteNumber number;
// an empty field anywhere ("1,,2", "1,2,", ",1", "1, ,2") is refused. False (and *values cleared) otherwise. The one parser of the number lists of options and scene keys.
bool ParseNumberList(const std::string& text, std::vector<double>* values);

class OptionParser {
 public:
  OptionParser(std::string program, std::string description);

  void Add(const std::string& name, std::string* value, const std::string& help);
  void Add(const std::string& name, int* value, const std::string& help);
  void Add(const std::string& name, int64_t* value, const std::string& help);
  void Add(const std::string& name, double* value, const std::string& help);
  void Add(const std::string& name, bool* value, const std::string& help);
  // A channel the program reads or writes, its default the current *channel (not empty). All of a program's
  // channels are renamed through one option, as ROS remaps topics: --channel DEFAULT=NAME (repeatable; an empty
  // NAME turns an input off where its help says so). An unknown DEFAULT is an error that lists the channels.
  void AddChannel(std::string* channel, const std::string& help);

  // Parses argv. Returns false with *error set on an unknown option, a missing or malformed value, or an
  // unreadable options file. Sets help_requested() on --help / -h (and returns true).
  bool Parse(int argc, char** argv, std::string* error);
  // Same, for "name value" pairs already split (used by Parse and by tests).
  bool ParseArgs(const std::vector<std::string>& args, std::string* error);

  bool help_requested() const { return help_requested_; }
  const std::vector<std::string>& positional() const { return positional_; }
  std::string Usage() const;
  std::string Effective() const;

 private:
  struct Option {
    std::string name;
    std::string help;
    bool is_flag = false;
    std::function<bool(const std::string&)> set;
    std::function<std::string()> get;
    // Optional, for an option that stands for several values (--channel): its own lines in Usage() and
    // Effective(), and what a bad value's error adds.
    std::function<std::string()> usage, effective, bad_value_hint;
  };
  struct Channel {
    std::string default_name;
    std::string* channel;
    std::string help;
  };
  Option* Find(const std::string& name);
  bool RenameChannel(const std::string& rename);
  bool ReadFile(const std::string& path, std::string* error);

  std::string program_;
  std::string description_;
  std::vector<Option> options_;
  std::vector<Channel> channels_;
  std::vector<std::string> positional_;
  bool help_requested_ = false;
};

// Parses argv for a process main(): prints usage and returns 0 into *exit_code when --help was asked, prints the
// error and usage and returns 2 into *exit_code on a bad command line; returns true when the program should run.
// An argument that is no option (a log path given without --log) is a bad command line unless allow_positional
// (the program reads positional() itself): a program that ignored it would run on something else without a word.
bool ParseCommandLineOrExit(OptionParser& parser, int argc, char** argv, int* exit_code, bool allow_positional = false);

}  // namespace objscan
