// Helpers shared by the test programs.
#pragma once

#include <sys/wait.h>

#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <sstream>
#include <functional>
#include <random>
#include <string>

#include <Eigen/Core>

namespace oslam::testing {

// A fresh empty folder under the system temp dir, removed by the destructor.
class TempDir {
 public:
  TempDir() {
    static std::mt19937_64 engine(std::random_device{}());
    path_ = std::filesystem::temp_directory_path() /
            ("oslam_test_" + std::to_string(engine()));
    std::filesystem::create_directories(path_);
  }
  ~TempDir() {
    std::error_code ec;
    std::filesystem::remove_all(path_, ec);
  }
  std::string Path(const std::string& name = "") const { return (path_ / name).string(); }

 private:
  std::filesystem::path path_;
};

// Central-difference Jacobian of f: R^n -> R^m at x.
inline Eigen::MatrixXd NumericJacobian(
    const std::function<Eigen::VectorXd(const Eigen::VectorXd&)>& f, const Eigen::VectorXd& x,
    double step = 1e-6) {
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

// A shell command's exit code and output, for tests of the oslam program.
struct CommandResult {
  int exit_code = -1;
  std::string out, err;
};

inline CommandResult RunShellCommand(const std::string& command) {
  TempDir dir;
  const int status =
      std::system((command + " >" + dir.Path("out") + " 2>" + dir.Path("err")).c_str());
  CommandResult result;
  result.exit_code = WIFEXITED(status) ? WEXITSTATUS(status) : -1;
  std::stringstream out, err;
  out << std::ifstream(dir.Path("out")).rdbuf();
  err << std::ifstream(dir.Path("err")).rdbuf();
  result.out = out.str();
  result.err = err.str();
  return result;
}

// Path of shared test data (../shared/data beside the repo), or "" when absent.
inline std::string SharedDataDir() {
  const std::filesystem::path dir =
      std::filesystem::path(OSLAM_SOURCE_DIR).parent_path() / "shared" / "data";
  return std::filesystem::is_directory(dir) ? dir.string() : "";
}

}  // namespace oslam::testing
