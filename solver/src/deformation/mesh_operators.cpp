// What depends on the rest mesh alone (MeshOperators): its cotangent weights, inspection,
// Laplacian and elimination order, or with multiresolution the base mesh, the detail encoding and
// the base's own operators; and which of the two a mesh gets.
#include "hdeform/deformer.h"

#include <tbb/parallel_invoke.h>
#include <tbb/task_group.h>

#include <functional>
#include <string>

#include "hdeform/errors.h"
#include "hdeform/laplacian.h"
#include "hdeform/stopwatch.h"
#include "hdeform/trace.h"

namespace hdeform {
namespace {

using Clock = SteadyClock;

// A base mesh from this size on is ordered by nested dissection, whatever the exact rule
// (kNestedDissectionFrom): every drag step and refinement iteration solves on it, where the
// minimum-degree order leaves a long chain at the top of its elimination tree that one thread
// sweeps; and its order is computed beside the detail encoding, so opening hardly waits for it
// (at 3.3M triangles, a base of 150,002 vertices: drag step 29.0-29.9 -> 25.7-25.8 ms, open
// 4.10 -> 4.15 s).
constexpr Eigen::Index kBaseNestedDissectionFrom = 100'000;

// The Laplacian, the inspection and the elimination order of a mesh solved at its own resolution.
void exact_operators(const Mesh& mesh, EliminationOrder order, MeshOperators& operators) {
  // (Scopes of their own, not one optional Scope re-emplaced: GCC's sanitizer builds warned that
  // the optional's Scope may be used uninitialized.)
  {
    const trace::Scope traced("cotangent weights", "set-up");
    operators.weights = cotangent_weights(mesh);
  }
  {
    const trace::Scope traced("Laplacian", "set-up");
    operators.laplacian = cotangent_laplacian(mesh, operators.weights);
  }
  // The ordering needs only the Laplacian's pattern, the inspection only the weights: the two run
  // side by side.
  tbb::parallel_invoke(
      [&] {
        const trace::Scope traced("mesh inspection", "set-up");
        operators.inspection = inspect_mesh(mesh, operators.weights);
      },
      [&] { operators.elimination_rank = elimination_ranks(operators.laplacian, order); });
}

}  // namespace

std::string_view to_string(Resolution resolution) {
  switch (resolution) {
    case Resolution::Automatic: return "automatic";
    case Resolution::Exact: return "exact";
    case Resolution::Multiresolution: return "multiresolution";
  }
  return "?";
}

std::optional<Resolution> parse_resolution(std::string_view name) {
  for (const auto resolution : {Resolution::Automatic, Resolution::Exact, Resolution::Multiresolution}) {
    if (name == to_string(resolution)) return resolution;
  }
  return std::nullopt;
}

Resolution resolution_for(Eigen::Index vertices, Resolution asked) {
  if (asked != Resolution::Automatic) return asked;
  return vertices >= kMultiresolutionFrom ? Resolution::Multiresolution : Resolution::Exact;
}

std::shared_ptr<const MeshOperators> MeshOperators::of(const Mesh& mesh, Resolution resolution, Eigen::Index base_vertices,
                                                       const ProgressCallback& progress) {
  validate_mesh(mesh);
  auto report = [&](std::string_view stage) {
    if (progress) progress(stage);
  };
  const auto start = Clock::now();
  auto operators = std::make_shared<MeshOperators>();
  if (resolution_for(mesh.vertex_count(), resolution) == Resolution::Multiresolution) {
    try {
      const std::string building = "building a base mesh of about " + std::to_string(base_vertices) + " vertices (multiresolution)";
      report(building);
      auto multiresolution = std::make_shared<Multiresolution>();
      multiresolution->requested_vertices = base_vertices;
      // The fine mesh's own weights and inspection (its partition needs them) do not need the
      // base: they fill the collapses' serial stretches. The collapses stay on this thread, which
      // reports their progress in tenths.
      tbb::task_group beside;
      beside.run([&] {
        const trace::Scope traced("cotangent weights and mesh inspection", "set-up");
        operators->weights = cotangent_weights(mesh);
        operators->inspection = inspect_mesh(mesh, operators->weights);
      });
      int tenths_reported = 0;
      const auto collapsed_share = [&](double share) {
        const int tenths = static_cast<int>(share * 10.0);
        if (tenths <= tenths_reported || tenths >= 10) return;
        tenths_reported = tenths;
        report(building + ": " + std::to_string(tenths * 10) + "%");
      };
      try {
        multiresolution->base = simplify_to_base(mesh, base_vertices, progress ? collapsed_share : std::function<void(double)>{});
      } catch (...) {
        beside.wait();
        throw;
      }
      beside.wait();
      report("encoding the detail of " + std::to_string(mesh.vertex_count()) + " vertices on the base of " +
             std::to_string(multiresolution->base.mesh.vertex_count()) + ", and the base's cotangent Laplacian");
      // Likewise the encoding and the base's operators (its elimination order runs on one thread).
      tbb::parallel_invoke([&] { multiresolution->encoding = DetailEncoding(mesh, multiresolution->base); },
                           [&] {
                             const auto base_start = Clock::now();
                             const Mesh& base = multiresolution->base.mesh;
                             auto base_operators = std::make_shared<MeshOperators>();
                             exact_operators(base, base.vertex_count() >= kBaseNestedDissectionFrom ? EliminationOrder::NestedDissection
                                                                                                     : EliminationOrder::Automatic,
                                             *base_operators);
                             base_operators->ms = milliseconds_since(base_start);
                             multiresolution->base_operators = std::move(base_operators);
                           });
      multiresolution->ms = milliseconds_since(start);
      operators->multiresolution = std::move(multiresolution);
      operators->ms = milliseconds_since(start);
      return operators;
    } catch (const SolveError& error) {
      if (resolution == Resolution::Multiresolution) throw;
      operators->exact_because = std::string("solved exactly: ") + error.what();
    }
  }
  report(elimination_order_for(mesh.vertex_count()) == EliminationOrder::NestedDissection
             ? "building the cotangent Laplacian and a nested-dissection order of its unknowns"
             : "building the cotangent Laplacian");
  exact_operators(mesh, EliminationOrder::Automatic, *operators);
  operators->ms = milliseconds_since(start);
  return operators;
}

std::shared_ptr<const SparseCholesky::Analysis> MeshOperators::last_analysis() const {
  const std::lock_guard lock(analysis_mutex_);
  return last_analysis_;
}

void MeshOperators::keep_analysis(std::shared_ptr<const SparseCholesky::Analysis> analysis) const {
  const std::lock_guard lock(analysis_mutex_);
  last_analysis_ = std::move(analysis);
}

}  // namespace hdeform
