// The numeric factorization, supernode by supernode (see tree_factorization.h).
#include <Eigen/Cholesky>
#include <Eigen/Core>

#include <algorithm>
#include <atomic>
#include <cmath>

#include "tree_factorization.h"

namespace hdeform::detail {
namespace {

using Stride = Eigen::OuterStride<>;
using PanelMap = Eigen::Map<Eigen::MatrixXd, 0, Stride>;
using ConstPanelMap = Eigen::Map<const Eigen::MatrixXd, 0, Stride>;

struct Workspace {
  std::vector<int> position;  // a row's index among the current supernode's rows (stale elsewhere)
  std::vector<double> panel;  // the current supernode's rows × columns, column-major
  std::vector<int> target;    // an update's rows' positions in the panel
  std::vector<double> sum;    // one column of an update
  std::vector<double> block;  // an updating supernode's rows, copied with a uniform stride
  std::vector<double> product;
};

// Views of the factor's column layout as the supernodes' panels. The row layout is only written,
// so it may be stored in single precision; the column layout is read back by the updates.
template <class RowValue>
struct Layout {
  const FactorPattern& pattern;
  double* column_value;
  RowValue* row_value;

  int first_column(int s) const { return pattern.supernodes.first_column[static_cast<std::size_t>(s)]; }
  // The rows of supernode s: its first column's rows, diagonal first.
  const int* rows(int s) const { return pattern.rows.data() + pattern.supernodes.rows_at[static_cast<std::size_t>(s)]; }
  int row_count(int s) const { return static_cast<int>(pattern.column_length(first_column(s))); }
  // Column k of s from s's row `from` on (from ≥ k: the column starts at its diagonal, row k).
  const double* column(int s, int k, int from) const {
    return column_value + pattern.column_begin[static_cast<std::size_t>(first_column(s) + k)] + (from - k);
  }
};

// panel −= L_d(rows first.., :) · L_d(rows first..last, :)ᵀ, each product entry added to the
// panel entry of its rows: the update of supernode d on the supernode whose panel this is.
template <class RowValue>
void subtract_update(const Layout<RowValue>& layout, const Supernodes::Update& update, int panel_first_column, int panel_rows, Workspace& w) {
  const int d = update.from;
  const int width = layout.pattern.supernodes.width(d);
  const int* rows = layout.rows(d) + update.first;
  const int targets = update.last - update.first;                 // columns of the panel updated
  const int length = layout.row_count(d) - update.first;          // panel rows updated
  int* target = w.target.data();
  for (int i = 0; i < length; ++i) target[i] = w.position[static_cast<std::size_t>(rows[i])];
  double* panel = w.panel.data();

  if (static_cast<long>(width) * targets * length >= kBlockedUpdateWork) {
    w.block.resize(static_cast<std::size_t>(length) * static_cast<std::size_t>(width));
    w.product.resize(static_cast<std::size_t>(length) * static_cast<std::size_t>(targets));
    for (int k = 0; k < width; ++k) {
      const double* column = layout.column(d, k, update.first);
      std::copy(column, column + length, w.block.data() + static_cast<std::size_t>(k) * static_cast<std::size_t>(length));
    }
    const ConstPanelMap block(w.block.data(), length, width, Stride(length));
    PanelMap product(w.product.data(), length, targets, Stride(length));
    product.noalias() = block * block.topRows(targets).transpose();
    for (int j = 0; j < targets; ++j) {
      double* out = panel + static_cast<std::ptrdiff_t>(rows[j] - panel_first_column) * panel_rows;
      const double* in = w.product.data() + static_cast<std::ptrdiff_t>(j) * length;
      for (int i = j; i < length; ++i) out[target[i]] -= in[i];
    }
    return;
  }

  double* sum = w.sum.data();
  for (int j = 0; j < targets; ++j) {
    double* out = panel + static_cast<std::ptrdiff_t>(rows[j] - panel_first_column) * panel_rows;
    if (width == 1) {
      const double* column = layout.column(d, 0, update.first);
      const double scale = column[j];
      for (int i = j; i < length; ++i) out[target[i]] -= column[i] * scale;
      continue;
    }
    std::fill(sum + j, sum + length, 0.0);
    for (int k = 0; k < width; ++k) {
      const double* column = layout.column(d, k, update.first);
      const double scale = column[j];
      for (int i = j; i < length; ++i) sum[i] += column[i] * scale;
    }
    for (int i = j; i < length; ++i) out[target[i]] -= sum[i];
  }
}

// Cholesky factorization of the panel's top square and the rows below it divided by its
// transpose (rows × width, column-major). False when a pivot is not positive.
bool factor_panel(double* panel, int rows, int width) {
  if (width >= kBlockedPanelWidth) {
    PanelMap whole(panel, rows, width, Stride(rows));
    Eigen::Ref<Eigen::MatrixXd, 0, Stride> square = whole.topRows(width);
    const Eigen::LLT<Eigen::Ref<Eigen::MatrixXd, 0, Stride>> llt(square);
    if (llt.info() != Eigen::Success || !(square.diagonal().array() > 0.0).all() || !square.diagonal().allFinite()) return false;
    if (rows > width) {
      auto below = whole.bottomRows(rows - width);
      square.triangularView<Eigen::Lower>().transpose().solveInPlace<Eigen::OnTheRight>(below);
    }
    return true;
  }
  for (int c = 0; c < width; ++c) {
    double* column = panel + static_cast<std::ptrdiff_t>(c) * rows;
    for (int k = 0; k < c; ++k) {
      const double* earlier = panel + static_cast<std::ptrdiff_t>(k) * rows;
      const double scale = earlier[c];
      for (int i = c; i < rows; ++i) column[i] -= earlier[i] * scale;
    }
    const double pivot = column[c];
    if (!(pivot > 0.0) || !std::isfinite(pivot)) return false;
    const double root = std::sqrt(pivot);
    column[c] = root;
    for (int i = c + 1; i < rows; ++i) column[i] /= root;
  }
  return true;
}

template <class RowValue>
bool factor_supernode(const PermutedMatrix& matrix, const Layout<RowValue>& layout, int s, Workspace& w) {
  const Supernodes& super = layout.pattern.supernodes;
  const int first = layout.first_column(s);
  const int width = super.width(s);
  const int m = layout.row_count(s);
  const int* rows = layout.rows(s);
  for (int i = 0; i < m; ++i) w.position[static_cast<std::size_t>(rows[i])] = i;
  double* panel = w.panel.data();
  std::fill(panel, panel + static_cast<std::ptrdiff_t>(m) * width, 0.0);
  for (int c = 0; c < width; ++c) {
    const auto j = static_cast<std::size_t>(first + c);
    double* column = panel + static_cast<std::ptrdiff_t>(c) * m;
    for (int p = matrix.diagonal[j]; p < matrix.start[j + 1]; ++p) {
      column[w.position[static_cast<std::size_t>(matrix.row[static_cast<std::size_t>(p)])]] += matrix.value[static_cast<std::size_t>(p)];
    }
  }
  for (std::size_t u = super.update_start[static_cast<std::size_t>(s)]; u < super.update_start[static_cast<std::size_t>(s) + 1]; ++u) {
    subtract_update(layout, super.updates[u], first, m, w);
  }
  if (!factor_panel(panel, m, width)) return false;

  // Into both layouts: column first + c holds the panel's column c from its diagonal down; row
  // i's entries in this supernode's columns are consecutive in the row layout.
  for (int c = 0; c < width; ++c) {
    const double* column = panel + static_cast<std::ptrdiff_t>(c) * m;
    std::copy(column + c, column + m, layout.column_value + layout.pattern.column_begin[static_cast<std::size_t>(first + c)]);
  }
  const int* position = super.row_position.data() + super.rows_at[static_cast<std::size_t>(s)];
  for (int i = 0; i < m; ++i) {
    RowValue* out = layout.row_value + position[i];
    for (int c = 0, count = std::min(i + 1, width); c < count; ++c) out[c] = static_cast<RowValue>(panel[static_cast<std::ptrdiff_t>(c) * m + i]);
  }
  return true;
}

// Every supernode, on the schedule's threads, each with a workspace of its own. (Here and not in
// factor_numeric: a lambda there that names Workspace, a type of this file alone, in a function
// other files link to, made GCC warn of the subobject's linkage.)
template <class RowValue>
bool factor_supernodes(const PermutedMatrix& matrix, const FactorPattern& pattern, RowValue* row_value, double* column_value) {
  const auto size = static_cast<std::size_t>(pattern.size());
  const Supernodes& super = pattern.supernodes;
  std::size_t tallest = 0;
  for (int s = 0; s < super.count(); ++s) tallest = std::max(tallest, pattern.column_length(super.first_column[static_cast<std::size_t>(s)]));
  std::vector<Workspace> workspaces(std::max<std::size_t>(1, super.schedule.subtrees.size()));
  for (auto& w : workspaces) {
    w.position.resize(size);
    w.panel.resize(super.largest_panel);
    w.target.resize(tallest);
    w.sum.resize(tallest);
  }
  const Layout<RowValue> layout{pattern, column_value, row_value};
  std::atomic<bool> failed{false};
  for_each_node(super.schedule, workspaces, failed, [&](Workspace& w, int s) {
    if (!factor_supernode(matrix, layout, s, w)) failed.store(true, std::memory_order_relaxed);
  });
  return !failed.load();
}

}  // namespace

template <class RowValue>
bool factor_numeric(const PermutedMatrix& matrix, const FactorPattern& pattern, UninitializedVector<RowValue>& row_value,
                    UninitializedVector<double>& column_value) {
  row_value.resize(pattern.nonzeros());  // every entry is written once, by the thread of its supernode
  column_value.resize(pattern.nonzeros());
  return factor_supernodes(matrix, pattern, row_value.data(), column_value.data());
}

template bool factor_numeric(const PermutedMatrix&, const FactorPattern&, UninitializedVector<double>&, UninitializedVector<double>&);
template bool factor_numeric(const PermutedMatrix&, const FactorPattern&, UninitializedVector<float>&, UninitializedVector<double>&);

}  // namespace hdeform::detail
