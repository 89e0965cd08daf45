// Errors reading or writing a recording. what() always names the file at fault.
#pragma once

#include <stdexcept>
#include <string>

namespace storey::bag {

class BagError : public std::runtime_error {
 public:
  BagError(const std::string& file, const std::string& problem)
      : std::runtime_error(file + ": " + problem), file_(file) {}
  const std::string& file() const { return file_; }

 private:
  std::string file_;
};

}  // namespace storey::bag
