#include "test_support.h"

#include <sys/wait.h>

#include <array>
#include <cstdio>
#include <cstdlib>
#include <fstream>
#include <random>
#include <sstream>

namespace hdeform::test {

std::filesystem::path shared_meshes() {
  if (const char* override_path = std::getenv("HDEFORM_SHARED_MESHES")) {
    return std::filesystem::is_directory(override_path) ? std::filesystem::path(override_path) : std::filesystem::path();
  }
  const auto beside_repository = std::filesystem::path(HDEFORM_SOURCE_DIR) / ".." / "shared" / "meshes";
  return std::filesystem::is_directory(beside_repository) ? beside_repository.lexically_normal() : std::filesystem::path();
}

Mesh planar_grid(int cells, double size, double jitter, unsigned seed) {
  std::mt19937 random(seed);
  std::uniform_real_distribution<double> offset(-jitter, jitter);
  const int side = cells + 1;
  const double step = size / cells;
  Mesh mesh;
  mesh.positions.resize(side * side, 3);
  for (int j = 0; j < side; ++j) {
    for (int i = 0; i < side; ++i) {
      const bool interior = i > 0 && j > 0 && i < cells && j < cells;
      const double dx = interior ? offset(random) * step : 0.0;
      const double dy = interior ? offset(random) * step : 0.0;
      mesh.positions.row(j * side + i) << i * step + dx, j * step + dy, 0.0;
    }
  }
  mesh.triangles.resize(2 * cells * cells, 3);
  int t = 0;
  for (int j = 0; j < cells; ++j) {
    for (int i = 0; i < cells; ++i) {
      const int a = j * side + i, b = a + 1, c = a + side + 1, d = a + side;
      if ((i + j) % 2 == 0) {
        mesh.triangles.row(t++) << a, b, c;
        mesh.triangles.row(t++) << a, c, d;
      } else {
        mesh.triangles.row(t++) << a, b, d;
        mesh.triangles.row(t++) << b, c, d;
      }
    }
  }
  return mesh;
}

std::vector<int> grid_boundary(int cells) {
  const int side = cells + 1;
  std::vector<int> boundary;
  for (int j = 0; j < side; ++j) {
    for (int i = 0; i < side; ++i) {
      if (i == 0 || j == 0 || i == cells || j == cells) boundary.push_back(j * side + i);
    }
  }
  return boundary;
}

TempDir::TempDir() {
  std::random_device entropy;
  path_ = std::filesystem::temp_directory_path() / ("hdeform-test-" + std::to_string(entropy()) + std::to_string(entropy()));
  std::filesystem::create_directories(path_);
}

TempDir::~TempDir() {
  std::error_code ignored;
  std::filesystem::remove_all(path_, ignored);
}

void TempDir::write(const std::string& name, const std::string& content) const {
  std::ofstream out(file(name), std::ios::binary);
  out << content;
}

Eigen::MatrixXd random_matrix(Eigen::Index rows, Eigen::Index columns, unsigned seed) {
  std::mt19937 random(seed);
  std::uniform_real_distribution<double> uniform(-1.0, 1.0);
  Eigen::MatrixXd matrix(rows, columns);
  for (Eigen::Index i = 0; i < matrix.size(); ++i) matrix(i) = uniform(random);
  return matrix;
}

std::vector<SolverBackend> available_backends() {
  std::vector<SolverBackend> available;
  for (auto backend : kSolverBackends) {
    if (backend_available(backend)) available.push_back(backend);
  }
  return available;
}

double relative_difference(const Eigen::MatrixXd& a, const Eigen::MatrixXd& b) {
  const double scale = b.cwiseAbs().maxCoeff();
  const double difference = (a - b).cwiseAbs().maxCoeff();
  return scale > 0.0 ? difference / scale : difference;
}

CommandOutcome run_command(const std::string& command, const std::filesystem::path& scratch) {
  const auto err_file = scratch / ".command-stderr";
  FILE* pipe = popen((command + " 2>'" + err_file.string() + "'").c_str(), "r");
  std::string out;
  std::array<char, 4096> buffer;
  while (const auto n = std::fread(buffer.data(), 1, buffer.size(), pipe)) out.append(buffer.data(), n);
  const int status = pclose(pipe);
  std::ifstream err_stream(err_file);
  std::stringstream err;
  err << err_stream.rdbuf();
  std::filesystem::remove(err_file);
  // Passed on, so that the test's own output holds what every command said: a failure shows it,
  // and in a sanitizer build a report from the command fails the test (tests/CMakeLists.txt).
  std::fputs(err.str().c_str(), stderr);
  return {WIFEXITED(status) ? WEXITSTATUS(status) : -1, out, err.str()};
}

}  // namespace hdeform::test
