#pragma once
// Shared helpers for the test suite: small meshes with known properties, access to the real
// meshes in ../shared/meshes (tests skip with the reason when they are absent), and a dense
// reference solver.
#include <gtest/gtest.h>

#include <Eigen/Dense>
#include <Eigen/SparseCore>
#include <filesystem>
#include <string>
#include <vector>

#include "hdeform/mesh.h"
#include "hdeform/sparse_cholesky.h"

namespace hdeform::test {

// ../shared/meshes beside the repository, or $HDEFORM_SHARED_MESHES; empty when absent.
std::filesystem::path shared_meshes();

// Skips the current test, printing why, when the shared meshes are absent.
#define HDEFORM_REQUIRE_SHARED_MESHES()                                                            \
  do {                                                                                             \
    if (::hdeform::test::shared_meshes().empty()) {                                                \
      GTEST_SKIP() << "../shared/meshes is absent (set HDEFORM_SHARED_MESHES to point at it)";     \
    }                                                                                              \
  } while (false)

// A planar (z = 0) triangulated grid of (cells+1)² vertices over [0, size]², with each vertex
// jittered in the plane by up to `jitter`·cell (deterministic, fixed seed) so that triangles are
// irregular, some obtuse.
Mesh planar_grid(int cells, double size = 1.0, double jitter = 0.0, unsigned seed = 1);

// Vertices of a planar grid on its outer boundary.
std::vector<int> grid_boundary(int cells);

// What a shell command did: its exit status (-1 when it did not exit normally) and its output.
struct CommandOutcome {
  int exit_code;
  std::string out;
  std::string err;
};
// Runs `command` with /bin/sh; its stderr is captured through a file in `scratch` (removed
// afterwards) and also copied to this process's stderr.
CommandOutcome run_command(const std::string& command, const std::filesystem::path& scratch);

// A fresh temporary directory, removed at destruction.
class TempDir {
 public:
  TempDir();
  ~TempDir();
  TempDir(const TempDir&) = delete;
  TempDir& operator=(const TempDir&) = delete;
  const std::filesystem::path& path() const { return path_; }
  std::filesystem::path file(const std::string& name) const { return path_ / name; }
  void write(const std::string& name, const std::string& content) const;

 private:
  std::filesystem::path path_;
};

// Maximum absolute entry of A − B over the maximum absolute entry of B (0 if B is zero).
double relative_difference(const Eigen::MatrixXd& a, const Eigen::MatrixXd& b);

// Entries uniform in [−1, 1], the same for the same seed.
Eigen::MatrixXd random_matrix(Eigen::Index rows, Eigen::Index columns, unsigned seed);
// The factorization backends this build has.
std::vector<SolverBackend> available_backends();

}  // namespace hdeform::test
