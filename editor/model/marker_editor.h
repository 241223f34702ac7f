#pragma once
// The marker pairs of the editor's transfer mode, with undo: add a pair, move either end to
// another vertex, delete one, load a file. A vertex carries at most one marker on each mesh.
// Free of any window code (tests drive it directly).
#include <optional>
#include <string>
#include <vector>

#include "hdeform/marker_io.h"

namespace hdeform::cli {

enum class MarkerSide { Source, Target };

class MarkerEditor {
 public:
  const MarkerPairs& pairs() const { return history_[index_]; }
  std::size_t size() const { return pairs().size(); }

  // The pair with `vertex` on `side`, or −1.
  int find(MarkerSide side, int vertex) const;

  // Each returns an explanation instead of changing anything when the vertex already carries
  // another pair's marker on that side. A change is one undo step.
  std::optional<std::string> add(int source_vertex, int target_vertex);
  std::optional<std::string> move(std::size_t pair, MarkerSide side, int vertex);
  void remove(std::size_t pair);
  void replace(MarkerPairs pairs);  // a loaded file

  bool can_undo() const { return index_ > 0; }
  bool can_redo() const { return index_ + 1 < history_.size(); }
  bool undo();
  bool redo();
  // Increases with every change, undo and redo: results computed from other markers are stale.
  std::uint64_t version() const { return version_; }

 private:
  void push(MarkerPairs pairs);

  std::vector<MarkerPairs> history_{MarkerPairs{}};
  std::size_t index_ = 0;
  std::uint64_t version_ = 0;
};

}  // namespace hdeform::cli
