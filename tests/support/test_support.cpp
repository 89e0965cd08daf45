#include "test_support.h"

#include <sys/wait.h>
#include <unistd.h>

#include <cstdio>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <sstream>
#include <stdexcept>

namespace storey::test {

std::string readFile(const std::string& path) {
  std::ifstream in(path, std::ios::binary);
  std::stringstream text;
  text << in.rdbuf();
  return text.str();
}

void writeFile(const std::string& path, const std::string& text) {
  const std::filesystem::path parent = std::filesystem::path(path).parent_path();
  if (!parent.empty()) std::filesystem::create_directories(parent);
  std::ofstream(path, std::ios::binary) << text;
}

std::string sourceDir() { return STOREY_SOURCE_DIR; }
std::string binaryDir() { return STOREY_BINARY_DIR; }
std::string highDomainQosFile() { return binaryDir() + "/tests/high_domain_qos.xml"; }

std::string sharedDataPath(const std::string& relative) {
  const char* override_dir = std::getenv("STOREY_SHARED_DATA");
  const std::filesystem::path base =
      override_dir ? std::filesystem::path(override_dir)
                   : std::filesystem::path(STOREY_SOURCE_DIR) / ".." / "shared" / "data";
  const std::filesystem::path path = base / relative;
  return std::filesystem::exists(path) ? std::filesystem::canonical(path).string() : "";
}

std::string makeTempDir(const std::string& prefix) {
  std::string pattern = (std::filesystem::temp_directory_path() / (prefix + "_XXXXXX")).string();
  if (!mkdtemp(pattern.data())) throw std::runtime_error("cannot create a temporary directory");
  return pattern;
}

CommandResult runCommand(const std::string& command) {
  CommandResult result;
  FILE* pipe = popen((command + " 2>&1").c_str(), "r");
  if (!pipe) return result;
  char buffer[4096];
  while (const std::size_t n = fread(buffer, 1, sizeof(buffer), pipe))
    result.output.append(buffer, n);
  const int status = pclose(pipe);
  result.status = WIFEXITED(status) ? WEXITSTATUS(status) : -1;
  return result;
}

Eigen::MatrixXd numericJacobian(const std::function<Eigen::VectorXd(const Eigen::VectorXd&)>& f,
                                const Eigen::VectorXd& x, double step) {
  const Eigen::VectorXd f0 = f(x);
  Eigen::MatrixXd jacobian(f0.size(), x.size());
  for (int i = 0; i < x.size(); ++i) {
    Eigen::VectorXd plus = x, minus = x;
    plus[i] += step;
    minus[i] -= step;
    jacobian.col(i) = (f(plus) - f(minus)) / (2.0 * step);
  }
  return jacobian;
}

}  // namespace storey::test
