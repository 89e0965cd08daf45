#include "args.h"

#include <algorithm>
#include <cmath>
#include <iostream>
#include <sstream>

namespace storey::cli {

Args::Args(std::string command, std::vector<std::string> tokens)
    : command_(std::move(command)), tokens_(std::move(tokens)) {}

Args& Args::usage(const std::string& synopsis, const std::string& description) {
  synopsis_ = synopsis;
  description_ = description;
  return *this;
}

Args& Args::option(const std::string& name, const std::string& value_name,
                   const std::string& help, const std::string& default_value) {
  specs_[name] = Spec{value_name, help, default_value, false};
  order_.push_back(name);
  return *this;
}

Args& Args::flag(const std::string& name, const std::string& help) {
  specs_[name] = Spec{"", help, "", true};
  order_.push_back(name);
  return *this;
}

std::string Args::helpText() const {
  std::ostringstream out;
  out << "usage: storey " << command_ << " " << synopsis_ << "\n\n" << description_ << "\n";
  if (!order_.empty()) out << "\noptions:\n";
  for (const auto& name : order_) {
    const Spec& spec = specs_.at(name);
    std::string left = "  --" + name + (spec.is_flag ? "" : " " + spec.value_name);
    out << left << std::string(left.size() < 28 ? 28 - left.size() : 1, ' ') << spec.help;
    if (!spec.default_value.empty()) out << " (default " << spec.default_value << ")";
    out << "\n";
  }
  out << "  --help                    show this text\n";
  return out.str();
}

bool Args::parse() {
  for (std::size_t i = 0; i < tokens_.size(); ++i) {
    const std::string& token = tokens_[i];
    if (token == "--help" || token == "-h") {
      std::cout << helpText();
      return false;
    }
    if (token.rfind("--", 0) == 0 && token.size() > 2) {
      std::string name = token.substr(2), value;
      const auto eq = name.find('=');
      bool has_inline = eq != std::string::npos;
      if (has_inline) {
        value = name.substr(eq + 1);
        name = name.substr(0, eq);
      }
      auto spec = specs_.find(name);
      if (spec == specs_.end()) throw UsageError("unknown option --" + name + " (see --help)");
      if (spec->second.is_flag) {
        if (has_inline) throw UsageError("--" + name + " takes no value");
        values_[name] = "1";
        continue;
      }
      if (!has_inline) {
        if (i + 1 >= tokens_.size()) throw UsageError("--" + name + " needs a value");
        value = tokens_[++i];
      }
      values_[name] = value;
      continue;
    }
    positionals_.push_back(token);
  }
  return true;
}

std::string Args::positional(std::size_t i, const std::string& what) const {
  if (i >= positionals_.size()) throw UsageError("missing " + what + " (see --help)");
  return positionals_[i];
}

std::optional<std::string> Args::optionalPositional(std::size_t i) const {
  if (i >= positionals_.size()) return std::nullopt;
  return positionals_[i];
}

bool Args::has(const std::string& name) const { return values_.count(name) > 0; }

std::string Args::get(const std::string& name) const {
  auto value = values_.find(name);
  if (value != values_.end()) return value->second;
  auto spec = specs_.find(name);
  if (spec == specs_.end()) throw std::logic_error("undeclared option --" + name);
  return spec->second.default_value;
}

double Args::getDouble(const std::string& name) const {
  const std::string text = get(name);
  try {
    std::size_t used = 0;
    const double value = std::stod(text, &used);
    if (used != text.size() || !std::isfinite(value)) throw std::invalid_argument(text);
    return value;
  } catch (const std::exception&) {
    throw UsageError("--" + name + " expects a finite number, got '" + text + "'");
  }
}

double Args::getDouble(const std::string& name, double min, double max) const {
  const double value = getDouble(name);
  if (value < min || value > max) {
    std::ostringstream out;
    out << "--" << name << " must lie in [" << min << ", " << max << "], got " << get(name);
    throw UsageError(out.str());
  }
  return value;
}

std::string Args::getChoice(const std::string& name,
                            const std::vector<std::string>& choices) const {
  std::string value = get(name);
  if (std::find(choices.begin(), choices.end(), value) != choices.end()) return value;
  std::string list;
  for (const std::string& c : choices) list += (list.empty() ? "" : ", ") + c;
  throw UsageError("--" + name + " must be one of " + list + ", got '" + value + "'");
}

long Args::getInt(const std::string& name) const {
  const std::string text = get(name);
  try {
    std::size_t used = 0;
    const long value = std::stol(text, &used);
    if (used != text.size()) throw std::invalid_argument(text);
    return value;
  } catch (const std::exception&) {
    throw UsageError("--" + name + " expects an integer, got '" + text + "'");
  }
}

bool Args::flagSet(const std::string& name) const { return values_.count(name) > 0; }

}  // namespace storey::cli
