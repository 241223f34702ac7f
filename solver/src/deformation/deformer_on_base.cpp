// The Deformer with multiresolution (multiresolution.h): the paper's update and the refinement run
// on the base's own Deformer; this one rebuilds the fine mesh from the base and puts the fine
// mesh's constrained vertices exactly where their constraints say (write_constrained, which the
// exact update's "targets" stage runs too).
#include <tbb/parallel_for.h>

#include <string>

#include "hdeform/counted.h"
#include "hdeform/deformer.h"
#include "hdeform/errors.h"
#include "hdeform/trace.h"

namespace hdeform {

void Deformer::set_up_on_base(const ProgressCallback& progress) {
  const auto& multiresolution = *operators_->multiresolution;
  DeformerOptions base_options = options_;
  base_options.resolution = Resolution::Exact;
  base_warnings_.clear();
  BaseConstraints carried = base_constraints(constraints_, rest_.triangles, multiresolution.encoding);
  EditConstraints& on_base = carried.constraints;
  // A handle that reaches no base vertex of its own: every base vertex under it already belongs
  // to the fixed set or an earlier handle (a small handle beside another set on a coarse base).
  for (std::size_t h = 0; h < on_base.handles.size(); ++h) {
    if (on_base.handles[h].empty() && !constraints_.handles[h].empty()) {
      const std::size_t painted = constraints_.handles[h].size();
      throw InputError("handle " + std::to_string(h + 1) + " (" + counted(painted, "vertex", "vertices") +
                       ") reaches no vertex of the base mesh (" + std::to_string(multiresolution.base.mesh.vertex_count()) + " vertices) that the fixed vertices or another handle do not hold already: paint it larger, or solve on "
                       "a larger base or exactly");
    }
  }
  const std::string base_size = std::to_string(multiresolution.base.mesh.vertex_count());
  for (std::size_t set = 0; set < carried.unheld_vertices.size(); ++set) {
    const std::size_t count = carried.unheld_vertices[set];
    if (count == 0) continue;
    const bool one = count == 1;
    const std::string which = set == 0 ? counted(count, "fixed vertex", "fixed vertices")
                                       : counted(count, "vertex", "vertices") + " of handle " + std::to_string(set);
    base_warnings_.push_back(which + (one ? " reaches" : " reach") +
                             " no vertex of the base mesh (" + base_size + " vertices): " + (one ? "it lies in a patch" : "they lie in patches") +
                             " smaller than a base triangle whose base vertices all belong to other sets. The base moves freely "
                             "there while " + (one ? "it stays" : "they stay") + " where the set says, stretching the triangles "
                             "between: paint " + (one ? "it" : "them") + " larger, or solve on a larger base or exactly");
  }
  base_ = std::make_unique<Deformer>(multiresolution.base.mesh, std::move(on_base), multiresolution.base_operators, base_options, progress);
  // The fine field: the base's, carried over the feet; exact at the fine constrained vertices.
  field_ = multiresolution.encoding.interpolate(base_->field());
  for (const int v : partition_.constrained_vertices) {
    field_[v] = partition_.role[static_cast<std::size_t>(v)] == VertexRole::Handle ? 1.0 : 0.0;
  }
  const double partition_ms = timings_.laplacian_ms;
  timings_ = base_->timings();
  timings_.laplacian_ms += partition_ms;
  timings_.base_ms = multiresolution.ms;
  base_positions_ = multiresolution.base.mesh.positions;
  edited_.resize(handle_count());
  rebuild_skip_ = multiresolution.encoding.triangles_only_of(partition_.constrained_vertices);
}

void Deformer::rebuild_from_base(Eigen::MatrixXd& positions) const {
  operators_->multiresolution->encoding.reconstruct(base_positions_, positions, rebuild_skip_);
  write_constrained(edited_, positions);
}

void Deformer::write_constrained(std::span<const HandleTransform> transforms, Eigen::MatrixXd& positions) const {
  const auto& vertices = partition_.constrained_vertices;
  tbb::parallel_for(tbb::blocked_range<std::size_t>(0, vertices.size(), 4096), [&](const auto& range) {
    for (std::size_t i = range.begin(); i != range.end(); ++i) {
      const int v = vertices[i];
      const auto vertex = static_cast<std::size_t>(v);
      if (partition_.role[vertex] == VertexRole::Handle) {
        const auto& transform = transforms[static_cast<std::size_t>(partition_.handle_index[vertex])];
        positions.row(v) = transform.apply(rest_.positions.row(v).transpose()).transpose();
      } else {
        positions.row(v) = rest_.positions.row(v);
      }
    }
  });
}

}  // namespace hdeform
