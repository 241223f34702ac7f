#pragma once
#include <nlohmann/json_fwd.hpp>

#include <string>

#include "hdeform/constraints.h"
#include "hdeform/handle_transform.h"
#include "hdeform/mesh.h"

namespace hdeform::cli {

struct RenderBenchOptions {
  std::string size = "1280x720";
  int samples = 0;  // 0: what the editor uses on this device
  int frames = 120;
  std::string device;
  bool validation = false;
  bool quiet = false;  // bench's --quiet: the chosen device is not announced
};

// Frame times on an offscreen target with frames in flight: the mesh standing still, and while a
// solver thread drags the handle and publishes every result; plus the cost of publishing
// positions and normals.
nlohmann::json bench_rendering(const Mesh& mesh, const EditConstraints& constraints, const HandleTransform& transform,
                               const RenderBenchOptions& options);

}  // namespace hdeform::cli
