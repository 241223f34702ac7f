#include "document.h"

#include <algorithm>
#include <limits>

#include "background_task.h"
#include "document_parts.h"
#include "hdeform/errors.h"

namespace hdeform::cli {
namespace {

constexpr std::size_t kHistoryLimit = 200;

}  // namespace

Document::Document(Session session, Mesh base, DeformerOptions options, Publish publish)
    : mesh_name_(session.mesh), applied_(session.applied), options_(options), publish_(std::move(publish)) {
  check_session_against_mesh(session, base.vertex_count(), SessionSource{"session", {}});
  // Where this session solves, decided once: a session that says keeps it, so that every stage,
  // the saved file and its replay solve alike.
  if (session.resolution != Resolution::Automatic) {
    options_.resolution = session.resolution;
    options_.base_vertices = session.base_vertices;
  } else {
    options_.resolution = resolution_for(base.vertex_count(), options_.resolution);
  }
  session.resolution = options_.resolution;
  session.base_vertices = options_.base_vertices;
  if (session.precision) options_.precision = *session.precision;
  session.precision = options_.precision;
  // The mesh is moved, not copied: at 3.3 million triangles each copy is 79 MB of fresh pages,
  // whose first writes cost this kind of host 0.2-0.3 s.
  validate_mesh(base, session.mesh.empty() ? "session mesh" : session.mesh);
  auto rest = std::make_shared<Mesh>(std::move(base));
  if (!session.applied.empty()) {
    Session applied_only = session;
    applied_only.current = {};
    rest->positions = replay_session(applied_only, *rest, options_);
  }
  rest_ = std::move(rest);
  load_stage(session.current);
  active_handle_ = handles_.empty() ? 0 : std::clamp(session.active_handle, 0, static_cast<int>(handles_.size()) - 1);
  history_.push_back({this->session(), rest_, "open"});
  // The set-up starts now, on the loading thread's time, rather than at the first poll: the
  // editor still has the mesh to hand to the renderer (at 13 million triangles, seconds).
  poll();
}

// Not made with the document: at 3.3 million triangles it took 0.43 s of opening, before the
// set-up could start, and only growing, shrinking and picking a connected part need it. The
// triangles never change, so one adjacency serves every rest shape.
const VertexAdjacency& Document::adjacency() const {
  if (!adjacency_ && adjacency_build_) {
    auto outcome = adjacency_build_->task.take();  // waits, if it is still being built
    adjacency_build_.reset();
    if (outcome.result) adjacency_.emplace(std::move(*outcome.result));
  }
  if (!adjacency_) adjacency_.emplace(rest_->triangles, rest_->vertex_count());
  return *adjacency_;
}

void Document::prepare_adjacency() {
  if (adjacency_ || adjacency_build_) return;
  adjacency_build_ = std::make_unique<AdjacencyBuild>();
  adjacency_build_->task.start("adjacency", [rest = rest_] { return VertexAdjacency(rest->triangles, rest->vertex_count()); });
}

const Document::PaintedLists& Document::painted() const {
  if (painted_.version == painted_version_) return painted_;
  PaintedLists lists;
  lists.handles.resize(handles_.size());
  for (std::size_t v = 0; v < labels_.size(); ++v) {
    if (roi_[v]) lists.region_of_interest.push_back(static_cast<int>(v));
    if (labels_[v] == kFixed) lists.fixed.push_back(static_cast<int>(v));
    if (labels_[v] >= 0) lists.handles[static_cast<std::size_t>(labels_[v])].push_back(static_cast<int>(v));
  }
  lists.version = painted_version_;
  painted_ = std::move(lists);
  return painted_;
}

EditStage Document::current_stage() const {
  EditStage stage;
  const PaintedLists& lists = painted();
  stage.region_of_interest = lists.region_of_interest;
  stage.fixed = lists.fixed;
  for (std::size_t h = 0; h < handles_.size(); ++h) {
    if (!lists.handles[h].empty()) stage.handles.push_back({lists.handles[h], handles_[h].transform});
  }
  stage.refine = refine_;
  stage.refine_settle = refine_settle_;
  return stage;
}

Session Document::session() const {
  Session session;
  session.mesh = mesh_name_;
  session.applied = applied_;
  session.current = current_stage();
  // The active handle among the non-empty ones.
  int active = 0;
  for (int h = 0; h < active_handle_ && h < static_cast<int>(handle_sizes_.size()); ++h) active += handle_sizes_[static_cast<std::size_t>(h)] > 0 ? 1 : 0;
  session.active_handle = session.current.handles.empty() ? 0 : std::min(active, static_cast<int>(session.current.handles.size()) - 1);
  session.resolution = options_.resolution;
  session.base_vertices = options_.base_vertices;
  session.precision = options_.precision;
  return session;
}

void Document::load_stage(const EditStage& stage) {
  ++painted_version_;
  const auto n = static_cast<std::size_t>(rest_->vertex_count());
  labels_.assign(n, kFree);
  roi_.assign(n, false);
  roi_count_ = stage.region_of_interest.size();
  for (const int v : stage.region_of_interest) roi_[static_cast<std::size_t>(v)] = true;
  for (const int v : stage.fixed) labels_[static_cast<std::size_t>(v)] = kFixed;
  handles_.clear();
  handle_sizes_.clear();
  for (std::size_t h = 0; h < stage.handles.size(); ++h) {
    for (const int v : stage.handles[h].vertices) labels_[static_cast<std::size_t>(v)] = static_cast<int>(h);
    handles_.push_back({stage.handles[h].transform});
    handle_sizes_.push_back(stage.handles[h].vertices.size());
  }
  set_refine(stage.refine);
  if (stage.refine_settle != refine_settle_) {
    // A session that stops elsewhere (written by `edit`, or before the settle test): its stage
    // is refined as it says, by a deformer set up for that.
    refine_settle_ = stage.refine_settle;
    stop_pipeline();
    deformer_.reset();
    deformer_constraints_ = {};
  }
  active_handle_ = std::min(active_handle_, std::max(0, static_cast<int>(handles_.size()) - 1));
}

void Document::relabel(int vertex, int label) {
  int& current = labels_[static_cast<std::size_t>(vertex)];
  if (current == label) return;
  ++painted_version_;
  if (current >= 0) --handle_sizes_[static_cast<std::size_t>(current)];
  if (label >= 0) ++handle_sizes_[static_cast<std::size_t>(label)];
  current = label;
}

void Document::refresh_pivot(int handle) {
  Eigen::Vector3d centroid = Eigen::Vector3d::Zero();
  std::size_t count = 0;
  for (std::size_t v = 0; v < labels_.size(); ++v) {
    if (labels_[v] != handle) continue;
    centroid += rest_->positions.row(static_cast<Eigen::Index>(v)).transpose();
    ++count;
  }
  if (count == 0) return;
  auto& transform = handles_[static_cast<std::size_t>(handle)].transform;
  transform = HandleTransform::about_pivot(transform.axis, centroid / static_cast<double>(count), transform.angle, transform.scale, transform.shift);
}

void Document::paint(std::span<const int> vertices, Layer layer, bool erase) {
  if (layer == Layer::RegionOfInterest) {
    for (const int v : vertices) {
      const auto vertex = static_cast<std::size_t>(v);
      if (roi_[vertex] == !erase) continue;
      roi_[vertex] = !erase;
      ++painted_version_;
      if (erase) --roi_count_;
      else ++roi_count_;
    }
    return;
  }
  if (layer == Layer::Handle && handles_.empty()) add_handle();
  const int label = layer == Layer::Fixed ? kFixed : active_handle_;
  std::vector<bool> touched(handles_.size(), false);
  for (const int v : vertices) {
    const int current = labels_[static_cast<std::size_t>(v)];
    if (erase) {
      if (current != label) continue;
      relabel(v, kFree);
    } else {
      relabel(v, label);
    }
    if (current >= 0) touched[static_cast<std::size_t>(current)] = true;
  }
  if (label >= 0) touched[static_cast<std::size_t>(label)] = true;
  for (std::size_t h = 0; h < handles_.size(); ++h) {
    if (touched[h]) refresh_pivot(static_cast<int>(h));
  }
}

std::vector<bool> Document::members(Layer layer) const {
  std::vector<bool> result(labels_.size());
  for (std::size_t v = 0; v < labels_.size(); ++v) {
    switch (layer) {
      case Layer::RegionOfInterest: result[v] = roi_[v]; break;
      case Layer::Fixed: result[v] = labels_[v] == kFixed; break;
      case Layer::Handle: result[v] = labels_[v] == active_handle_; break;
    }
  }
  return result;
}

void Document::set_members(Layer layer, const std::vector<bool>& wanted) {
  std::vector<int> added, removed;
  const auto now = members(layer);
  for (std::size_t v = 0; v < wanted.size(); ++v) {
    if (wanted[v] && !now[v]) added.push_back(static_cast<int>(v));
    if (!wanted[v] && now[v]) removed.push_back(static_cast<int>(v));
  }
  paint(removed, layer, true);
  paint(added, layer, false);
}

void Document::invert(Layer layer) {
  auto wanted = members(layer);
  for (std::size_t v = 0; v < wanted.size(); ++v) {
    // Fixed and handle take only vertices that no other class holds.
    const bool free_for_layer = layer == Layer::RegionOfInterest || labels_[v] == kFree || wanted[v];
    wanted[v] = !wanted[v] && free_for_layer;
  }
  set_members(layer, wanted);
}

void Document::grow(Layer layer) {
  auto wanted = grown(members(layer), adjacency());
  if (layer != Layer::RegionOfInterest) {
    const auto now = members(layer);
    for (std::size_t v = 0; v < wanted.size(); ++v) wanted[v] = wanted[v] && (now[v] || labels_[v] == kFree);
  }
  set_members(layer, wanted);
}

void Document::shrink(Layer layer) { set_members(layer, shrunk(members(layer), adjacency())); }

void Document::clear(Layer layer) { set_members(layer, std::vector<bool>(labels_.size(), false)); }

void Document::set_active_handle(int handle) {
  if (handle >= 0 && handle < static_cast<int>(handles_.size())) active_handle_ = handle;
}

int Document::add_handle() {
  ++painted_version_;
  handles_.push_back({HandleTransform::about_pivot(Eigen::Vector3d::UnitZ(), Eigen::Vector3d::Zero(), 0.0)});
  handle_sizes_.push_back(0);
  active_handle_ = static_cast<int>(handles_.size()) - 1;
  return active_handle_;
}

void Document::remove_handle(int handle) {
  if (handle < 0 || handle >= static_cast<int>(handles_.size())) return;
  ++painted_version_;
  for (auto& label : labels_) {
    if (label == handle) label = kFree;
    else if (label > handle) --label;
  }
  handles_.erase(handles_.begin() + handle);
  handle_sizes_.erase(handle_sizes_.begin() + handle);
  active_handle_ = std::min(active_handle_, std::max(0, static_cast<int>(handles_.size()) - 1));
}

std::size_t Document::fixed_count() const { return painted().fixed.size(); }

std::size_t Document::handle_size(int handle) const { return handle_sizes_[static_cast<std::size_t>(handle)]; }

void Document::set_pose(int handle, const Eigen::Vector3d& axis, double angle, double scale, const Eigen::Vector3d& shift) {
  auto& transform = handles_[static_cast<std::size_t>(handle)].transform;
  transform = HandleTransform::about_pivot(axis, transform.pivot, angle, scale, shift);
}

void Document::reset_poses() {
  for (auto& handle : handles_) {
    handle.transform = HandleTransform::about_pivot(handle.transform.axis, handle.transform.pivot, 0.0, 1.0, Eigen::Vector3d::Zero());
  }
}

void Document::apply() {
  const EditStage stage = current_stage();
  if (stage.handles.empty()) return;
  auto rest = std::make_shared<Mesh>(*rest_);
  rest->positions = result();
  applied_.push_back(stage);
  rest_ = std::move(rest);
  reset_poses();
  for (std::size_t h = 0; h < handles_.size(); ++h) refresh_pivot(static_cast<int>(h));
}

void Document::commit(std::string what) {
  Snapshot snapshot{session(), rest_, std::move(what)};
  const Snapshot& last = history_[history_index_];
  if (snapshot.session == last.session && snapshot.rest == last.rest) return;
  history_.resize(history_index_ + 1);
  history_.push_back(std::move(snapshot));
  if (history_.size() > kHistoryLimit) {
    history_.erase(history_.begin());
    saved_index_ = saved_index_ == 0 ? history_.size() : saved_index_ - 1;
  }
  history_index_ = history_.size() - 1;
}

void Document::restore(const Snapshot& snapshot) {
  applied_ = snapshot.session.applied;
  rest_ = snapshot.rest;
  active_handle_ = snapshot.session.active_handle;
  options_.resolution = snapshot.session.resolution;
  options_.base_vertices = snapshot.session.base_vertices;
  options_.precision = snapshot.session.precision.value_or(FactorPrecision::Double);
  load_stage(snapshot.session.current);
}

// A change not yet committed (a value still being typed, a field dragged) is what the user
// sees: undo first records it, so that it can be redone, and so that it goes back to the step
// before it rather than to an older one.
bool Document::undo() {
  commit();
  if (!can_undo()) return false;
  last_history_step_ = history_[history_index_].what;
  const Snapshot& snapshot = history_[--history_index_];
  restore(snapshot);
  return true;
}

// After an uncommitted change the redo branch is gone (commit() truncates it): redo never
// replaces what the user sees with an older state.
bool Document::redo() {
  commit();
  if (!can_redo()) return false;
  const Snapshot& snapshot = history_[++history_index_];
  last_history_step_ = snapshot.what;
  restore(snapshot);
  return true;
}

bool Document::modified() const { return history_index_ != saved_index_; }
void Document::mark_saved() { saved_index_ = history_index_; }
void Document::mark_saved(const Session& written) {
  if (session() == written) mark_saved();
}
void Document::mark_unsaved() { saved_index_ = std::numeric_limits<std::size_t>::max(); }

}  // namespace hdeform::cli
