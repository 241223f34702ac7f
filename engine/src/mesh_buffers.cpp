#include "hdeform/engine/mesh_buffers.h"

#include <algorithm>
#include <cstring>
#include <string>

#include "hdeform/errors.h"
#include "hdeform/mesh.h"

namespace hdeform::engine {
namespace {

// Bytes written between two calls of the progress: a few milliseconds of first writes.
constexpr std::size_t kPieceBytes = std::size_t{4} << 20;

// Runs write(begin, end) over [0, count) in pieces of about kPieceBytes (`item_bytes` each item),
// telling `progress` after each; false when it said stop.
template <class Write, class Tell>
bool in_pieces(std::size_t count, std::size_t item_bytes, Write&& write, Tell&& tell) {
  const std::size_t piece = std::max<std::size_t>(1, kPieceBytes / item_bytes);
  for (std::size_t begin = 0; begin < count; begin += piece) {
    const std::size_t end = std::min(count, begin + piece);
    write(begin, end);
    if (!tell((end - begin) * item_bytes)) return false;
  }
  return true;
}

}  // namespace

MeshBuffers::MeshBuffers(const VulkanContext& context, std::size_t vertex_count, std::size_t triangle_count, uint32_t frames)
    : context_(context), vertex_count_(vertex_count), triangle_count_(triangle_count) {
  try {
    indices_ = context.create_buffer(sizeof(uint32_t) * 3 * triangle_count, VK_BUFFER_USAGE_INDEX_BUFFER_BIT);
    frames_.resize(frames);
    for (Frame& frame : frames_) {
      frame.geometry = context.create_buffer(sizeof(float) * 6 * vertex_count, VK_BUFFER_USAGE_VERTEX_BUFFER_BIT);
      frame.attributes = context.create_buffer(sizeof(float) * 2 * vertex_count, VK_BUFFER_USAGE_VERTEX_BUFFER_BIT);
    }
  } catch (...) {
    release();
    throw;
  }
}

MeshBuffers::~MeshBuffers() { release(); }

void MeshBuffers::release() {
  context_.destroy(indices_);
  for (Frame& frame : frames_) {
    context_.destroy(frame.geometry);
    context_.destroy(frame.attributes);
  }
}

bool MeshBuffers::fill(const Eigen::MatrixXi& triangles, const GeometrySnapshot* snapshot, const Progress& progress) {
  filled_ = false;
  if (triangles.cols() != 3 || static_cast<std::size_t>(triangles.rows()) != triangle_count_) {
    throw InputError("mesh to draw: " + std::to_string(triangles.rows()) + " triangles of " + std::to_string(triangles.cols()) +
                                " corners, where buffers for " + std::to_string(triangle_count_) + " triangles were made");
  }
  const bool whole_snapshot = snapshot != nullptr && snapshot->only_vertices == nullptr && snapshot->position_normal.size() == 6 * vertex_count_;
  const std::size_t total = sizeof(uint32_t) * 3 * triangle_count_ + sizeof(float) * 2 * vertex_count_ + frames_.size() * sizeof(float) * 8 * vertex_count_;
  std::size_t done = 0;
  auto tell = [&](std::size_t bytes) {
    done += bytes;
    return !progress || progress(total == 0 ? 1.0 : static_cast<double>(done) / static_cast<double>(total));
  };

  auto* indices = static_cast<uint32_t*>(indices_.mapped);
  const auto vertices = static_cast<uint32_t>(vertex_count_);
  const bool indices_written = in_pieces(triangle_count_, 3 * sizeof(uint32_t), [&](std::size_t begin, std::size_t end) {
    bool in_range = true;
    for (std::size_t t = begin; t < end; ++t) {
      for (int k = 0; k < 3; ++k) {
        const auto v = static_cast<uint32_t>(triangles(static_cast<Eigen::Index>(t), k));
        in_range = in_range && v < vertices;
        indices[3 * t + static_cast<std::size_t>(k)] = v;
      }
    }
    // The message names the first bad triangle of all, as every other check of triangles does.
    if (!in_range) validate_triangles(triangles, static_cast<Eigen::Index>(vertex_count_), "mesh to draw");
  }, tell);
  if (!indices_written) return false;

  attributes_.clear();
  attributes_.reserve(2 * vertex_count_);
  if (!in_pieces(vertex_count_, 2 * sizeof(float), [&](std::size_t, std::size_t end) { attributes_.resize(2 * end, 0.0f); }, tell)) return false;
  for (Frame& frame : frames_) {
    frame.geometry_version = 0;
    auto* attributes = static_cast<float*>(frame.attributes.mapped);
    if (!in_pieces(vertex_count_, 2 * sizeof(float), [&](std::size_t begin, std::size_t end) {
          std::fill(attributes + 2 * begin, attributes + 2 * end, 0.0f);
        }, tell)) {
      return false;
    }
    // Without the whole geometry to copy, zeros: the renderer's first upload then writes into
    // pages written before.
    auto* geometry = static_cast<float*>(frame.geometry.mapped);
    if (!in_pieces(vertex_count_, 6 * sizeof(float), [&](std::size_t begin, std::size_t end) {
          if (whole_snapshot) std::memcpy(geometry + 6 * begin, snapshot->position_normal.data() + 6 * begin, sizeof(float) * 6 * (end - begin));
          else std::fill(geometry + 6 * begin, geometry + 6 * end, 0.0f);
        }, tell)) {
      return false;
    }
    if (whole_snapshot) frame.geometry_version = snapshot->version;
  }
  filled_ = true;
  return true;
}

}  // namespace hdeform::engine
