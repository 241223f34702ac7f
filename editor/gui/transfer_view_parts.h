#pragma once
// TransferView's insides, shared by the files that define it: transfer_view.cpp (loading,
// markers, cameras, compute) and transfer_panel.cpp (its panel and overlays). Internal.
#include <optional>
#include <string>
#include <vector>

#include "gui/transfer_view.h"
#include "hdeform/engine/geometry_exchange.h"
#include "hdeform/engine/mesh_renderer.h"
#include "commands/cli_support.h"
#include "gui/view_picking.h"

namespace hdeform::cli {

struct TransferView::Side {
  Mesh rest;
  std::string path;
  std::unique_ptr<engine::GeometryExchange> exchange;
  std::unique_ptr<engine::GeometryPublisher> publisher;
  std::unique_ptr<engine::MeshRenderer> renderer;
  ViewPicker picker;
  engine::Camera camera;
  bool camera_fitted = false;
  VkRect2D area{};
  const Eigen::MatrixXd* shown = nullptr;
  engine::RenderSettings settings;
  engine::UpAxis up = engine::UpAxis::Z;  // each mesh its own: scans come Y-up or Z-up

  float aspect() const { return static_cast<float>(area.extent.width) / static_cast<float>(std::max(area.extent.height, 1u)); }
};

struct TransferView::Loaded {
  Mesh source_rest;
  Mesh target;
  std::string source_path;
  std::string target_path;
  std::vector<Eigen::MatrixXd> poses;
  std::vector<std::string> pose_names;
  std::vector<std::string> pose_paths;
  std::optional<MarkerPairs> markers;
  std::string markers_path;
  int source_column = 1;
};

struct TransferView::Computed {
  std::vector<Eigen::MatrixXd> results;
  TransferSetupTimings setup;
  Summary pose_ms;
  std::size_t factorizations = 0;
  std::size_t mismatches = 0;
  std::uint64_t markers_version = 0;
  TransferMethod method = TransferMethod::Correspondence;
  std::vector<std::string> warnings;
};

// Paths separated by white space; a name with * or ? expands to the matching files of its
// folder, sorted. Throws InputError for a folder that cannot be listed or a name that matches
// nothing.
std::vector<std::string> expand_paths(const std::string& text);
void copy_text(char* buffer, std::size_t size, const std::string& text);

}  // namespace hdeform::cli
