// Command-line arguments of one storey subcommand: positionals, --name value options and
// --flags, with a usage text and strict checking (an unknown option is an error).
#pragma once

#include <map>
#include <optional>
#include <stdexcept>
#include <string>
#include <vector>

namespace storey::cli {

class UsageError : public std::runtime_error {
 public:
  using std::runtime_error::runtime_error;
};

class Args {
 public:
  // `command` is e.g. "optimize"; `tokens` are the words after it.
  Args(std::string command, std::vector<std::string> tokens);

  // Declare what the command takes (for --help and strict parsing), then parse().
  Args& usage(const std::string& synopsis, const std::string& description);
  Args& option(const std::string& name, const std::string& value_name, const std::string& help,
               const std::string& default_value = "");
  Args& flag(const std::string& name, const std::string& help);
  // Returns false when --help was given (usage already printed): the command returns 0.
  bool parse();

  const std::vector<std::string>& positionals() const { return positionals_; }
  std::string positional(std::size_t i, const std::string& what) const;  // required
  std::optional<std::string> optionalPositional(std::size_t i) const;
  std::string get(const std::string& name) const;  // declared default if absent
  bool has(const std::string& name) const;
  // A finite number (NaN and infinity are refused: no option has a use for them).
  double getDouble(const std::string& name) const;
  // A finite number within [min, max]; the error names the option and the range.
  double getDouble(const std::string& name, double min, double max) const;
  long getInt(const std::string& name) const;
  // One of `choices`; the error names the option and lists them.
  std::string getChoice(const std::string& name, const std::vector<std::string>& choices) const;
  bool flagSet(const std::string& name) const;
  const std::string& command() const { return command_; }
  std::string helpText() const;

 private:
  struct Spec {
    std::string value_name, help, default_value;
    bool is_flag = false;
  };
  std::string command_;
  std::vector<std::string> tokens_;
  std::string synopsis_, description_;
  std::vector<std::string> order_;
  std::map<std::string, Spec> specs_;
  std::map<std::string, std::string> values_;
  std::vector<std::string> positionals_;
};

}  // namespace storey::cli
