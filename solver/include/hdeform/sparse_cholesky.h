#pragma once
/// @file
/// One sparse Cholesky factorization, P A Pᵀ = L Lᵀ, computed once and reused for every
/// right-hand side: the harmonic field, the quaternion components and x, y, z.
///
/// The backends differ only in how L is computed (ordering and numeric factorization). Solves
/// always run through one kernel that reads L once per triangular sweep for all the columns of a
/// block: the solve is memory-bound, so k columns in one pass cost far less than k passes.
///
/// Both sweeps are gathers (row j of L for the forward sweep, column j for the backward one), so
/// each unknown is summed in one fixed order. That lets the sweeps run in parallel over disjoint
/// subtrees of the elimination tree — each thread reads only its part of the factor — while the
/// result stays bit-identical for any number of threads.
#include <Eigen/Core>
#include <Eigen/SparseCore>
#include <cstdint>
#include <memory>
#include <optional>
#include <span>
#include <string>
#include <string_view>
#include <vector>

namespace hdeform {

/// Which code computes L (the solves always run through the one kernel).
enum class SolverBackend {
  Tree,     ///< ours: elimination_ranks (or a given) ordering, rows of L computed in parallel over elimination subtrees
  Eigen,    ///< Eigen SimplicialLLT with AMD ordering
  Cholmod,  ///< CHOLMOD supernodal LLT through Eigen's CholmodSupport
};
/// Every backend, in the order the benchmarks report them.
inline constexpr SolverBackend kSolverBackends[] = {SolverBackend::Tree, SolverBackend::Eigen, SolverBackend::Cholmod};

/// The backend's name: "tree", "eigen", "cholmod".
std::string_view to_string(SolverBackend backend);
/// The backend named `name`, or nullopt.
std::optional<SolverBackend> parse_backend(std::string_view name);
/// Whether this build has the backend (CHOLMOD is optional).
bool backend_available(SolverBackend backend);
/// The backend measured faster on buddha-206k (see README, Performance).
SolverBackend default_backend();

/// How a fill-reducing elimination order is found.
enum class EliminationOrder {
  Automatic,         ///< MinimumDegree below kNestedDissectionFrom unknowns, NestedDissection from there
  MinimumDegree,     ///< approximate minimum degree (AMD)
  NestedDissection,  ///< METIS nested dissection
};
/// Nested dissection costs several times AMD's time (buddha-206k: 33 against 355 ms) and pays it
/// back only on large meshes: at 103K vertices it removes 10% of L's nonzeros and no drag time;
/// at 411K (the Buddha subdivided once) 23% of them, 30% of the factorization and 25% of each
/// drag's solve (README, Performance).
inline constexpr Eigen::Index kNestedDissectionFrom = 250'000;
/// The order's name: "automatic", "minimum degree", "nested dissection".
std::string_view to_string(EliminationOrder order);
/// What Automatic means for a matrix of `unknowns` rows.
EliminationOrder elimination_order_for(Eigen::Index unknowns);

/// An elimination order of a symmetric matrix's pattern (both triangles stored): rank[i] is the
/// step that eliminates unknown i. Deterministic: the same pattern always gives the same ranks.
std::vector<int> elimination_ranks(const Eigen::SparseMatrix<double>& matrix, EliminationOrder order = EliminationOrder::Automatic);

/// How L is stored for the solves.
enum class FactorPrecision {
  Double,  ///< L in double: one pass per solve
  Single,  ///< L rounded to single (half the bytes of values), solves refined to double accuracy
           ///< against A by correction steps that stop on a residual test
};
/// The precision's name: "double", "single".
std::string_view to_string(FactorPrecision precision);
/// The precision named `name`, or nullopt.
std::optional<FactorPrecision> parse_precision(std::string_view name);

/// A sparse Cholesky factorization P A Pᵀ = L Lᵀ of a symmetric positive definite matrix, kept for
/// many solves: factor() once, then solve_block() per right-hand side block (allocation-free,
/// parallel over elimination subtrees, the same bits on any number of threads).
class SparseCholesky {
 public:
  /// An empty factorization; factor() fills it.
  SparseCholesky();
  ~SparseCholesky();
  SparseCholesky(SparseCholesky&&) noexcept;
  SparseCholesky& operator=(SparseCholesky&&) noexcept;

  /// What the analysis of a sparsity pattern found (ordering, elimination tree, pattern of L and
  /// its split over threads); opaque, shared by factorizations of matrices with that pattern.
  struct Analysis;
  struct Factor;  ///< L in the two layouts the sweeps read

  /// Analyses and factors a symmetric positive definite matrix (both triangles stored).
  /// Throws SolveError when it is not positive definite or the factorization fails, and (Tree)
  /// before L's values are allocated when they would not fit in the memory available
  /// (MemAvailable, or the process's memory cgroup where that allows less), naming both figures.
  ///  - ordering (Tree only; the other backends order by themselves): ordering[i] is unknown i's
  ///    rank in a fill-reducing elimination order, lowest first; empty: AMD on this matrix.
  ///  - reuse (Tree only): an earlier factorization's analysis(); taken, and the analysis
  ///    skipped, when this matrix has exactly the pattern it was made for.
  ///  - precision: Single computes each part of L in double and stores it in single precision,
  ///    measures on a known solution how much one correction step gains, and keeps it when a
  ///    step gains at least 100 times; otherwise it keeps L in double and precision_note() says why.
  void factor(const Eigen::SparseMatrix<double>& matrix, SolverBackend backend, std::span<const int> ordering = {},
              const std::shared_ptr<const Analysis>& reuse = nullptr, FactorPrecision precision = FactorPrecision::Double);
  /// This factorization's analysis, for reuse; null unless the backend is Tree.
  std::shared_ptr<const Analysis> analysis() const;
  /// Whether the last factor() took the given analysis instead of analysing.
  bool reused_analysis() const;

  /// Whether nothing has been factored.
  bool empty() const { return size() == 0; }
  /// The number of unknowns.
  Eigen::Index size() const;
  /// The backend that computed L.
  SolverBackend backend() const { return backend_; }
  /// The nonzeros of L.
  Eigen::Index factor_nonzeros() const;
  /// The precision the solves read L in.
  FactorPrecision precision() const;
  /// Why single precision was asked for and not used (the matrix is too ill-conditioned); empty
  /// otherwise.
  const std::string& precision_note() const;

  /// What the refinement of single-precision solves has done.
  struct Refinement {
    std::int64_t solves = 0;       ///< refined solves so far
    std::int64_t corrections = 0;  ///< correction steps over all of them
    int most_corrections = 0;      ///< the most steps one solve took
    std::int64_t stalled = 0;      ///< solves stopped because a step no longer halved the backward error
    double contraction = 0.0;      ///< measured at set-up: the error after one step over the error before
  };
  /// The refinement's counts so far (all zero with a double factor).
  Refinement refinement() const;

  /// factor_row()[i]: the row of unknown i in factor order.
  const std::vector<int>& factor_row() const;

  /// Solves A X = B in place for a row-major block in factor order: row factor_row()[i] holds the
  /// `columns` values of unknown i, consecutive rows `stride` doubles apart. Subtrees of the
  /// elimination tree run concurrently. Safe to call concurrently on distinct blocks. Allocation-free
  /// in double; in single, once the refinement's workspaces exist (one per concurrent solve, kept).
  /// Any stride gives the same bits; fast_solve_stride(columns) is the fastest.
  void solve_block(double* block, int columns, int stride) const;
  /// The stride at which solve_block() is fastest. It solves eight columns at a time, the last
  /// one to eight left, each four columns at a time where a row has room for them (the pad is
  /// read, never written): so the last three columns are padded to four and the last five to
  /// seven to eight, while one or two stay as they are (they waste more on a pad than the vectors
  /// save). So 3 → 4, 5 → 8, 13 → 16, 55 → 56, and 1, 2, 4, 8, 9, 124 stay.
  static constexpr int fast_solve_stride(int columns) {
    const int last = columns % 8;
    return columns + (last == 3 ? 1 : last > 4 ? 8 - last : 0);
  }

  /// How the solve is split: independent subtrees (one list of columns per worker, ascending) and
  /// the columns above them, solved after (forward) or before (backward) the subtrees.
  std::size_t subtree_count() const;
  double top_fraction() const;  ///< share of the factor's nonzeros outside the subtrees

  /// Convenience (allocates): X = A⁻¹ B with B and X in natural order, column-major.
  Eigen::MatrixXd solve(const Eigen::MatrixXd& rhs) const;

 private:
  std::unique_ptr<Factor> factor_;
  SolverBackend backend_ = SolverBackend::Tree;
};

/// How the columns of one solve are spread over threads. Each group is one row-major block solved
/// by one pass over the factor; groups run concurrently.
enum class SolveSchedule {
  Blocked,       ///< all columns in one group
  PerColumn,     ///< one group per column
  ThreadGroups,  ///< as many groups as threads, columns split evenly
};

/// The schedule's name: "blocked", "per-column", "thread-groups".
std::string_view to_string(SolveSchedule schedule);
/// The schedule named `name`, or nullopt.
std::optional<SolveSchedule> parse_schedule(std::string_view name);
/// The schedule measured fastest for the drag update (see README, Performance).
SolveSchedule default_schedule();

/// k right-hand-side columns in factor order, split into groups per a schedule.
class ColumnBlocks {
 public:
  ColumnBlocks() = default;
  /// `threads` only matters for ThreadGroups (0: the current TBB concurrency).
  ColumnBlocks(Eigen::Index rows, int columns, SolveSchedule schedule, int threads = 0);

  /// The number of rows (unknowns).
  Eigen::Index rows() const { return rows_; }
  /// The number of columns.
  int columns() const { return static_cast<int>(group_of_column_.size()); }
  /// The number of groups, each solved by one pass over the factor.
  int groups() const { return static_cast<int>(groups_.size()); }

  /// The value of a row (in factor order) in a column.
  double& at(Eigen::Index row, int column) {
    const auto& slot = group_of_column_[static_cast<std::size_t>(column)];
    auto& group = groups_[static_cast<std::size_t>(slot.group)];
    return group.values[static_cast<std::size_t>(row * group.stride + slot.offset)];
  }
  /// The value of a row (in factor order) in a column.
  double at(Eigen::Index row, int column) const { return const_cast<ColumnBlocks*>(this)->at(row, column); }

  /// Solves one group against the factor (one pass over it for all the group's columns).
  void solve_group(const SparseCholesky& factor, int group);
  /// Solves every group, groups concurrently.
  void solve(const SparseCholesky& factor);

 private:
  struct Group {
    int columns = 0;
    int stride = 0;              ///< SparseCholesky::fast_solve_stride(columns)
    std::vector<double> values;  ///< rows × stride, row-major
  };
  struct Slot {
    int group = 0;
    int offset = 0;
  };
  Eigen::Index rows_ = 0;
  std::vector<Group> groups_;
  std::vector<Slot> group_of_column_;
};

}  // namespace hdeform
