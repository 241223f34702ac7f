#pragma once
#include <algorithm>
#include <numeric>
#include <vector>

namespace hdeform::detail {

// Union-find with path halving; the root of a set is its smallest member, so results do not
// depend on the order of unions.
class DisjointSets {
 public:
  explicit DisjointSets(std::size_t n = 0) { reset(n); }
  // n singletons again, keeping the storage.
  void reset(std::size_t n) {
    parent_.resize(n);
    std::iota(parent_.begin(), parent_.end(), 0);
  }
  int find(int v) {
    while (parent_[static_cast<std::size_t>(v)] != v) {
      auto& p = parent_[static_cast<std::size_t>(v)];
      p = parent_[static_cast<std::size_t>(p)];
      v = p;
    }
    return v;
  }
  void unite(int a, int b) {
    a = find(a);
    b = find(b);
    if (a != b) parent_[static_cast<std::size_t>(std::max(a, b))] = std::min(a, b);
  }

 private:
  std::vector<int> parent_;
};

}  // namespace hdeform::detail
