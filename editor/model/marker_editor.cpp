#include "marker_editor.h"

#include <algorithm>

namespace hdeform::cli {
namespace {

const std::vector<int>& side_of(const MarkerPairs& pairs, MarkerSide side) { return side == MarkerSide::Source ? pairs.source : pairs.target; }
const char* name_of(MarkerSide side) { return side == MarkerSide::Source ? "source" : "target"; }

}  // namespace

int MarkerEditor::find(MarkerSide side, int vertex) const {
  const auto& vertices = side_of(pairs(), side);
  const auto it = std::find(vertices.begin(), vertices.end(), vertex);
  return it == vertices.end() ? -1 : static_cast<int>(it - vertices.begin());
}

std::optional<std::string> MarkerEditor::add(int source_vertex, int target_vertex) {
  for (const auto& [side, vertex] : {std::pair{MarkerSide::Source, source_vertex}, std::pair{MarkerSide::Target, target_vertex}}) {
    if (const int taken = find(side, vertex); taken >= 0) {
      return std::string(name_of(side)) + " vertex " + std::to_string(vertex) + " already has marker " + std::to_string(taken + 1);
    }
  }
  MarkerPairs next = pairs();
  next.source.push_back(source_vertex);
  next.target.push_back(target_vertex);
  push(std::move(next));
  return std::nullopt;
}

std::optional<std::string> MarkerEditor::move(std::size_t pair, MarkerSide side, int vertex) {
  if (pair >= size()) return "no marker " + std::to_string(pair + 1);
  if (const int taken = find(side, vertex); taken >= 0) {
    if (static_cast<std::size_t>(taken) == pair) return std::nullopt;
    return std::string(name_of(side)) + " vertex " + std::to_string(vertex) + " already has marker " + std::to_string(taken + 1);
  }
  MarkerPairs next = pairs();
  (side == MarkerSide::Source ? next.source : next.target)[pair] = vertex;
  push(std::move(next));
  return std::nullopt;
}

void MarkerEditor::remove(std::size_t pair) {
  if (pair >= size()) return;
  MarkerPairs next = pairs();
  next.source.erase(next.source.begin() + static_cast<std::ptrdiff_t>(pair));
  next.target.erase(next.target.begin() + static_cast<std::ptrdiff_t>(pair));
  push(std::move(next));
}

void MarkerEditor::replace(MarkerPairs pairs) { push(std::move(pairs)); }

void MarkerEditor::push(MarkerPairs pairs) {
  history_.resize(index_ + 1);
  history_.push_back(std::move(pairs));
  ++index_;
  ++version_;
}

bool MarkerEditor::undo() {
  if (!can_undo()) return false;
  --index_;
  ++version_;
  return true;
}

bool MarkerEditor::redo() {
  if (!can_redo()) return false;
  ++index_;
  ++version_;
  return true;
}

}  // namespace hdeform::cli
