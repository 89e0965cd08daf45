// Shared fixtures for storey's tests: paths to the source tree, the shared data sets
// (skipping with a printed reason where they are absent), temporary folders, and
// numeric differentiation for Jacobian tests.
#pragma once

#include <gtest/gtest.h>

#include <Eigen/Core>
#include <functional>
#include <string>

namespace storey::test {

std::string sourceDir();
std::string binaryDir();
// Path of ../shared/data/<relative>, or "" when it does not exist.
std::string sharedDataPath(const std::string& relative);
// A fresh, empty temporary directory (removed at process exit is not guaranteed).
std::string makeTempDir(const std::string& prefix = "storey_test");

// The whole file as it is ("" when it cannot be read).
std::string readFile(const std::string& path);
// Writes `text` as the whole file at `path`, creating its folder when missing.
void writeFile(const std::string& path, const std::string& text);

// A shell command's exit status (-1 when it did not exit normally) and its stdout and
// stderr, joined: for tests that run the storey executable.
struct CommandResult {
  int status = -1;
  std::string output;
};
CommandResult runCommand(const std::string& command);

// Central-difference Jacobian of f at x; f maps R^n to R^m.
Eigen::MatrixXd numericJacobian(const std::function<Eigen::VectorXd(const Eigen::VectorXd&)>& f,
                                const Eigen::VectorXd& x, double step = 1e-6);

}  // namespace storey::test

// Skips the current test, printing why, when a shared data file is absent.
#define STOREY_REQUIRE_DATA(var, relative)                                                       \
  const std::string var =                                                                        \
      ::storey::test::sharedDataPath(relative); /* NOLINT(bugprone-macro-parentheses): a name */ \
  if ((var).empty()) {                                                                           \
    GTEST_SKIP() << "shared data file ../shared/data/" << (relative) << " is absent";            \
  }
