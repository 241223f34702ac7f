#include "hdeform/deformer.h"

#include <tbb/flow_graph.h>
#include <tbb/parallel_sort.h>
#include <tbb/task_arena.h>
#include <tbb/parallel_for.h>

#include <algorithm>
#include <chrono>
#include <limits>
#include <optional>
#include <numbers>
#include <stdexcept>

#include "refinement/arap_refinement.h"
#include "hdeform/deformation_field.h"
#include "hdeform/errors.h"
#include "hdeform/handle_shape.h"
#include "hdeform/harmonic_field.h"
#include "hdeform/laplacian.h"
#include "hdeform/poisson.h"
#include "hdeform/trace.h"
#include "hdeform/stopwatch.h"

namespace hdeform {
namespace {

using Clock = std::chrono::steady_clock;

using Message = tbb::flow::continue_msg;
using Node = tbb::flow::continue_node<Message>;
constexpr std::size_t kRowGrain = 1024;

std::shared_ptr<const Mesh> required(std::shared_ptr<const Mesh> rest) {
  if (!rest) throw std::invalid_argument("Deformer: no rest mesh");
  return rest;
}

}  // namespace

// The per-update task graph. One handle:
//   start ─┬─► maps (blend along h) ──────────┬─► rhs ─► solve x, y, z ─► write free rows
//          └─► constrained targets ───────────┘
// Several handles: start ─► field rhs ─► solve q0..q3, s ─► components ─► maps ─► ...
// Each solve runs its columns concurrently against the one factor: as column groups and, within
// a group, over subtrees of the elimination tree (SolveSchedule decides the grouping).
struct Deformer::UpdateArena {
  tbb::task_arena arena;
};

struct Deformer::UpdateGraph {
  // Inputs of the update in flight.
  std::span<const HandleTransform> transforms;
  Eigen::MatrixXd* positions = nullptr;

  std::vector<Eigen::Matrix3d> maps;  // several handles
  AxialMaps axial_maps;               // one handle
  ColumnBlocks coordinates;
  ColumnBlocks fields;
  Eigen::Matrix<double, Eigen::Dynamic, kInterpolatedComponents, Eigen::RowMajor> components;
  std::vector<InterpolatedValue> handle_values;

  tbb::flow::graph graph;
  tbb::flow::broadcast_node<Message> start{graph};
  // One refinement iteration: assemble ─► solve ─► mix ─► fit. The positions are written once
  // after a run of them.
  tbb::flow::broadcast_node<Message> refine_start{graph};
  std::vector<std::unique_ptr<Node>> nodes;

  // A stage, named in the trace, whose duration is added to `*stage_ms` (zeroed before each
  // update) when given.
  template <class Body>
  Node& add(const char* name, double* stage_ms, Body body) {
    nodes.push_back(std::make_unique<Node>(graph, [name, body, stage_ms](const Message&) {
      const trace::Scope traced(name, "update");
      const auto began = Clock::now();
      body();
      if (stage_ms != nullptr) *stage_ms += milliseconds_since(began);
    }));
    return *nodes.back();
  }
};

Deformer::Deformer(Mesh rest, EditConstraints constraints, DeformerOptions options, const ProgressCallback& progress)
    : Deformer(std::move(rest), std::move(constraints), nullptr, options, progress) {}

Deformer::Deformer(Mesh rest, EditConstraints constraints, std::shared_ptr<const MeshOperators> operators, DeformerOptions options,
                   const ProgressCallback& progress)
    : Deformer(std::make_shared<const Mesh>(std::move(rest)), std::move(constraints), std::move(operators), options, progress) {}

Deformer::Deformer(std::shared_ptr<const Mesh> rest, EditConstraints constraints, std::shared_ptr<const MeshOperators> operators,
                   DeformerOptions options, const ProgressCallback& progress)
    : shared_rest_(required(std::move(rest))), rest_(*shared_rest_), constraints_(std::move(constraints)), options_(options), operators_(std::move(operators)),
      update_arena_(std::make_unique<UpdateArena>()) {
  auto report = [&](std::string_view stage) {
    if (progress) progress(stage);
  };
  validate_mesh(rest_);
  if (constraints_.handles.empty()) throw InputError("no handle: at least one handle vertex list is needed");

  auto start = Clock::now();
  if (operators_) {
    const bool sizes_fit = operators_->weights.kind.size() == static_cast<std::size_t>(rest_.triangle_count()) &&
                           (operators_->multiresolution ? operators_->multiresolution->encoding.fine_count() == rest_.vertex_count()
                                                        : operators_->laplacian.rows() == rest_.vertex_count());
    if (!sizes_fit) throw std::invalid_argument("Deformer: the operators given are of another mesh");
    if (options_.resolution != Resolution::Automatic && operators_->resolution() != options_.resolution) operators_.reset();
  }
  if (!operators_) operators_ = MeshOperators::of(rest_, options_.resolution, options_.base_vertices, progress);
  const auto& weights = operators_->weights;
  std::optional<trace::Scope> stage;
  stage.emplace("vertex partition", "set-up");
  partition_ = partition_vertices(rest_, weights, constraints_);
  if (!partition_.handles_without_sink.empty()) {
    const int h = partition_.handles_without_sink.front() + 1;
    throw InputError((handle_count() == 1 ? std::string("the handle") : "handle " + std::to_string(h)) +
                     " has no fixed vertex in its part of the mesh (its region of interest): the harmonic field needs sinks "
                     "(value 0) as well as the handle (value 1), or it is 1 everywhere and undefined as a guide. Fix some "
                     "vertices there, or give a region of interest (the vertices outside it stay fixed).");
  }
  handle_warnings_ = handle_shape_warnings(rest_, constraints_);
  timings_.laplacian_ms = milliseconds_since(start);
  if (operators_->multiresolution) {
    stage.reset();
    set_up_on_base(progress);
    return;
  }
  const auto& laplacian = operators_->laplacian;

  stage.emplace("factorization", "set-up");
  report("factoring " + std::to_string(partition_.free_vertices.size()) + " unknowns (" +
         std::string(to_string(options_.backend)) + (options_.precision == FactorPrecision::Single ? ", single precision" : "") + ")");
  system_ = std::make_unique<DirichletSystem>(laplacian, partition_, options_.backend, operators_->elimination_rank,
                                              operators_->last_analysis(), options_.precision);
  if (auto analysis = system_->factor().analysis()) operators_->keep_analysis(std::move(analysis));
  timings_.factor_ms = system_->factor_ms();

  stage.emplace("harmonic field", "set-up");
  report("solving the harmonic field");
  start = Clock::now();
  field_ = harmonic_field(*system_, partition_);
  timings_.field_ms = milliseconds_since(start);
  prepare_update_triangles();

  stage.emplace("update graph", "set-up");
  // The update graph and every buffer it touches, allocated once; the graph attaches to the
  // arena it is created in.
  update_arena_->arena.execute([this] { graph_ = std::make_unique<UpdateGraph>(); });
  auto& g = *graph_;
  const auto free_rows = system_->free_count();
  const auto vertex_count = rest_.vertex_count();
  g.coordinates = ColumnBlocks(free_rows, 3, options_.schedule);

  auto& t = last_update_;
  Node& targets = g.add("targets", &t.targets_ms, [this] { write_constrained(graph_->transforms, *graph_->positions); });
  tbb::flow::make_edge(g.start, targets);

  Node* maps_node = nullptr;
  if (handle_count() == 1) {
    g.axial_maps.coefficients.resize(update_triangles_.size());
    maps_node = &g.add("maps", &t.maps_ms, [this] { sample_blend_maps(triangle_field_, graph_->transforms[0], graph_->axial_maps); });
    tbb::flow::make_edge(g.start, *maps_node);
  } else {
    g.fields = ColumnBlocks(free_rows, kInterpolatedComponents, options_.schedule);
    g.components.resize(vertex_count, kInterpolatedComponents);
    g.handle_values.resize(handle_count());
    g.maps.resize(update_triangles_.size());
    Node& field_rhs = g.add("field right-hand side", &t.field_ms, [this] {
      auto& u = *graph_;
      for (std::size_t k = 0; k < u.handle_values.size(); ++k) u.handle_values[k] = interpolation_value(u.transforms[k]);
      const auto identity = identity_interpolation_value();
      for (const int v : partition_.constrained_vertices) {
        const auto vertex = static_cast<std::size_t>(v);
        u.components.row(v) = partition_.role[vertex] == VertexRole::Handle
                                  ? u.handle_values[static_cast<std::size_t>(partition_.handle_index[vertex])]
                                  : identity;
      }
      tbb::parallel_for(tbb::blocked_range<Eigen::Index>(0, system_->free_count(), kRowGrain), [&](const auto& range) {
        for (Eigen::Index row = range.begin(); row != range.end(); ++row) {
          InterpolatedValue value = InterpolatedValue::Zero();
          for (const auto& entry : system_->coupling(static_cast<int>(row))) value -= entry.weight * u.components.row(entry.vertex);
          for (int c = 0; c < kInterpolatedComponents; ++c) u.fields.at(row, c) = value(c);
        }
      });
    });
    tbb::flow::make_edge(g.start, field_rhs);
    Node& components = g.add("field components", &t.field_ms, [this] {
      auto& u = *graph_;
      tbb::parallel_for(tbb::blocked_range<Eigen::Index>(0, system_->free_count(), kRowGrain), [&](const auto& range) {
        for (Eigen::Index row = range.begin(); row != range.end(); ++row) {
          const int vertex = system_->vertex_of_row()[static_cast<std::size_t>(row)];
          for (int c = 0; c < kInterpolatedComponents; ++c) u.components(vertex, c) = u.fields.at(row, c);
        }
      });
    });
    Node& field_solve = g.add("field solve", &t.field_ms, [this] { graph_->fields.solve(system_->factor()); });
    tbb::flow::make_edge(field_rhs, field_solve);
    tbb::flow::make_edge(field_solve, components);
    maps_node = &g.add("maps", &t.maps_ms, [this] { sample_interpolated_maps(graph_->components, update_mesh_triangles_, graph_->maps); });
    tbb::flow::make_edge(components, *maps_node);
  }

  Node& rhs = handle_count() == 1
                  ? g.add("right-hand side", &t.rhs_ms, [this] { assembler_->assemble(graph_->axial_maps, *graph_->positions, graph_->coordinates); })
                  : g.add("right-hand side", &t.rhs_ms, [this] { assembler_->assemble(graph_->maps, *graph_->positions, graph_->coordinates); });
  tbb::flow::make_edge(*maps_node, rhs);
  tbb::flow::make_edge(targets, rhs);
  Node& write = g.add("write-back", &t.write_ms, [this] {
    auto& u = *graph_;
    tbb::parallel_for(tbb::blocked_range<Eigen::Index>(0, system_->free_count(), kRowGrain), [&](const auto& range) {
      for (Eigen::Index row = range.begin(); row != range.end(); ++row) {
        const int vertex = system_->vertex_of_row()[static_cast<std::size_t>(row)];
        for (int c = 0; c < 3; ++c) (*u.positions)(vertex, c) = u.coordinates.at(row, c);
      }
    });
  });
  Node& solve = g.add("solve", &t.solve_ms, [this] { graph_->coordinates.solve(system_->factor()); });
  tbb::flow::make_edge(rhs, solve);
  tbb::flow::make_edge(solve, write);
  edited_.resize(handle_count());
  if (options_.prepare_refinement) {
    stage.emplace("refinement set-up", "set-up");
    report("preparing the as-rigid-as-possible refinement");
    prepare_refinement();
  }
}

void Deformer::prepare_refinement() {
  graph_->graph.wait_for_all();
  refinement_ = std::make_unique<detail::ArapRefinement>(rest_, operators_->weights, *system_, update_triangles_, options_.refinement);
  auto& g = *graph_;
  std::vector<Node*> chain;
  // Each stage keeps its own time (RefinementTimings); the graph adds none.
  chain.push_back(&g.add("refinement right-hand side", nullptr, [this] { refinement_->assemble(); }));
  chain.push_back(&g.add("refinement solve", nullptr, [this] { refinement_->solve(); }));
  chain.push_back(&g.add("refinement acceleration", nullptr, [this] { refinement_->mix(); }));
  chain.push_back(&g.add("refinement rotations", nullptr, [this] { refinement_->fit(); }));
  tbb::flow::make_edge(g.refine_start, *chain.front());
  for (std::size_t k = 1; k < chain.size(); ++k) tbb::flow::make_edge(*chain[k - 1], *chain[k]);
}

void Deformer::prepare_update_triangles() {
  // Only triangles with a free corner enter the right-hand side. They are renumbered in the order
  // in which the assembly visits its rows (factor order), so that the per-triangle maps it reads
  // lie close together in memory; the maps are computed in that order too.
  const auto& row_of_vertex = system_->row_of_vertex();
  std::vector<std::pair<int, int>> first_row;  // (smallest free row among the corners, triangle)
  for (Eigen::Index t = 0; t < rest_.triangle_count(); ++t) {
    if (operators_->weights.kind[static_cast<std::size_t>(t)] == ElementKind::Ignored) continue;
    int row = std::numeric_limits<int>::max();
    for (int k = 0; k < 3; ++k) {
      const int r = row_of_vertex[static_cast<std::size_t>(rest_.triangles(t, k))];
      if (r >= 0) row = std::min(row, r);
    }
    if (row != std::numeric_limits<int>::max()) first_row.emplace_back(row, static_cast<int>(t));
  }
  tbb::parallel_sort(first_row.begin(), first_row.end());
  const auto count = static_cast<Eigen::Index>(first_row.size());
  update_triangles_.resize(first_row.size());
  Mesh update_mesh{rest_.positions, Eigen::MatrixXi(count, 3)};
  CotangentWeights update_weights;
  update_weights.half_cotangent.resize(count, 3);
  update_weights.kind.resize(first_row.size());
  for (Eigen::Index k = 0; k < count; ++k) {
    const int t = first_row[static_cast<std::size_t>(k)].second;
    update_triangles_[static_cast<std::size_t>(k)] = t;
    update_mesh.triangles.row(k) = rest_.triangles.row(t);
    update_weights.half_cotangent.row(k) = operators_->weights.half_cotangent.row(t);
    update_weights.kind[static_cast<std::size_t>(k)] = operators_->weights.kind[static_cast<std::size_t>(t)];
  }
  update_mesh_triangles_ = std::move(update_mesh.triangles);
  update_mesh.triangles = update_mesh_triangles_;
  triangle_field_ = barycenter_values(field_, update_mesh_triangles_);
  assembler_ = std::make_unique<PoissonAssembler>(update_mesh, update_weights, *system_);
}

Deformer::~Deformer() {
  if (graph_) graph_->graph.wait_for_all();
}

std::vector<std::string> Deformer::warnings() const {
  auto lines = operators_->inspection.warnings();
  lines.insert(lines.end(), partition_.warnings.begin(), partition_.warnings.end());
  lines.insert(lines.end(), handle_warnings_.begin(), handle_warnings_.end());
  lines.insert(lines.end(), base_warnings_.begin(), base_warnings_.end());
  if (!operators_->exact_because.empty()) lines.push_back(operators_->exact_because);
  if (const auto& multiresolution = operators_->multiresolution) {
    // The collapses stop short of the size asked for where none is allowed any more: a small base
    // asked of a mesh with a long boundary keeps every boundary vertex.
    const Eigen::Index kept = multiresolution->base.mesh.vertex_count(), asked = multiresolution->requested_vertices;
    if (kept > asked + asked / 10) {
      lines.push_back("the base mesh has " + std::to_string(kept) + " vertices where " + std::to_string(asked) +
                      " were asked for: no more collapses were allowed (boundary vertices and parts of a few triangles stay, and a "
                      "collapse may not change the topology, fold a triangle or leave a sliver)");
    }
  }
  if ((base_ || system_) && !system().factor().precision_note().empty()) lines.push_back(system().factor().precision_note());
  return lines;
}

void Deformer::deform(std::span<const HandleTransform> transforms, Eigen::MatrixXd& positions, RefinementStart start) {
  update(transforms, positions, start, nullptr);
}

void Deformer::update(std::span<const HandleTransform> transforms, Eigen::MatrixXd& positions, RefinementStart start,
                      const std::span<const int>* only_vertices) {
  if (transforms.size() != handle_count()) {
    throw std::invalid_argument("deform: " + std::to_string(transforms.size()) + " transforms for " +
                                std::to_string(handle_count()) + " handles");
  }
  const trace::Scope traced("update", "update");
  const auto began = Clock::now();
  positions.resize(rest_.vertex_count(), 3);
  std::copy(transforms.begin(), transforms.end(), edited_.begin());
  refinement_start_ = start;
  if (base_) {
    base_->deform(transforms, base_positions_, start);
    const auto detail_began = Clock::now();
    if (only_vertices) {
      operators_->multiresolution->encoding.reconstruct(base_positions_, positions, *only_vertices);
      write_constrained(transforms, positions);
    } else {
      rebuild_from_base(positions);
    }
    last_update_ = base_->last_update();
    last_update_.detail_ms = milliseconds_since(detail_began);
    last_update_.total_ms = milliseconds_since(began);
    return;
  }
  last_update_ = UpdateTimings{};
  if (std::all_of(transforms.begin(), transforms.end(), [](const HandleTransform& t) { return t.is_identity(); })) {
    // Nothing moved: the rest shape is the method's answer, to the last bit.
    positions = rest_.positions;
    refinement_pending_ = true;
    last_update_.total_ms = milliseconds_since(began);
    return;
  }
  graph_->transforms = transforms;
  graph_->positions = &positions;
  update_arena_->arena.execute([this] {
    graph_->start.try_put(Message());
    graph_->graph.wait_for_all();
  });
  refinement_pending_ = true;
  last_update_.total_ms = milliseconds_since(began);
}

void Deformer::begin_refinement(const Eigen::MatrixXd& positions) {
  auto& refinement = *refinement_;
  const auto vertices = refinement.rotation_vertices();
  const auto triangles = refinement.energy_triangles();
  auto rotations = refinement.field_rotations();
  auto scales = refinement.triangle_scales();
  if (std::all_of(edited_.begin(), edited_.end(), [](const HandleTransform& t) { return t.is_identity(); })) {
    refinement.begin_at_rest();
    return;
  }
  update_arena_->arena.execute([&] {
    if (handle_count() == 1) {
      const HandleTransform& handle = edited_[0];
      refinement.set_turn_axis(std::abs(handle.angle) > std::numbers::pi ? std::optional<Eigen::Vector3d>(handle.axis) : std::nullopt);
      // A drag that only moves the handle leaves the field's rotations and scales as they were.
      const bool same_field = field_of_ && field_of_->axis == handle.axis && field_of_->angle == handle.angle && field_of_->scale == handle.scale;
      field_of_ = handle;
      if (same_field) {
        refinement.begin(positions, refinement_start_);
        return;
      }
      tbb::parallel_for(tbb::blocked_range<std::size_t>(0, vertices.size(), kRowGrain), [&](const auto& range) {
        for (std::size_t i = range.begin(); i != range.end(); ++i) rotations[i] = blend_rotation(handle, field_(vertices[i]));
      });
      tbb::parallel_for(tbb::blocked_range<std::size_t>(0, triangles.size(), kRowGrain), [&](const auto& range) {
        for (std::size_t c = range.begin(); c != range.end(); ++c) {
          const auto t = triangles[c];
          const double h = (field_(rest_.triangles(t, 0)) + field_(rest_.triangles(t, 1)) + field_(rest_.triangles(t, 2))) / 3.0;
          scales[c] = blend_scale(handle, h);
        }
      });
    } else {
      field_of_.reset();
      refinement.set_turn_axis(std::nullopt);  // interpolated quaternions turn less than half a turn
      const auto& components = graph_->components;
      tbb::parallel_for(tbb::blocked_range<std::size_t>(0, vertices.size(), kRowGrain), [&](const auto& range) {
        for (std::size_t i = range.begin(); i != range.end(); ++i) {
          rotations[i] = interpolated_rotation(components.row(vertices[i]));
        }
      });
      tbb::parallel_for(tbb::blocked_range<std::size_t>(0, triangles.size(), kRowGrain), [&](const auto& range) {
        for (std::size_t c = range.begin(); c != range.end(); ++c) {
          const auto t = triangles[c];
          scales[c] = (components(rest_.triangles(t, 0), 4) + components(rest_.triangles(t, 1), 4) + components(rest_.triangles(t, 2), 4)) / 3.0;
        }
      });
    }
    refinement.begin(positions, refinement_start_);
  });
}

bool Deformer::deform_vertices(std::span<const HandleTransform> transforms, Eigen::MatrixXd& positions, std::span<const int> vertices,
                               RefinementStart start) {
  if (!base_) {
    deform(transforms, positions, start);
    return true;
  }
  expect_result_rows(positions, "deform_vertices");
  update(transforms, positions, start, &vertices);
  return false;
}

void Deformer::complete(Eigen::MatrixXd& positions) {
  if (!base_) return;
  rebuild_from_base(positions);
}

int Deformer::refine(Eigen::MatrixXd& positions, int max_iterations) {
  expect_result_rows(positions, "refine");
  if (base_) {
    // The base writes its rows as part of its iterations' time, as before; the rebuild is apart.
    const int iterations = base_->refine(base_positions_, max_iterations);
    if (iterations > 0) rebuild_from_base(positions);
    return iterations;
  }
  const int iterations = refine_unwritten(positions, max_iterations);
  if (iterations > 0) {
    // The last iteration's time includes the write, so that one iteration at a time (the bench's
    // way) is timed whole.
    const auto start = Clock::now();
    write_refined(positions);
    refinement_->timings().total_ms += milliseconds_since(start);
  }
  return iterations;
}

int Deformer::refine_unwritten(const Eigen::MatrixXd& positions, int max_iterations) {
  expect_result_rows(positions, "refine_unwritten");
  if (base_) return base_->refine_unwritten(base_positions_, max_iterations);
  if (!refinement_) prepare_refinement();
  if (refinement_pending_) {
    const trace::Scope traced("refinement start", "refinement");
    begin_refinement(positions);
    refinement_pending_ = false;
  }
  int iterations = 0;
  while (iterations < max_iterations && !refinement_->status().converged) {
    const trace::Scope traced("refinement iteration", "refinement", refinement_->status().iterations + 1);
    const auto start = Clock::now();
    update_arena_->arena.execute([this] {
      graph_->refine_start.try_put(Message());
      graph_->graph.wait_for_all();
    });
    refinement_->timings().total_ms = milliseconds_since(start);
    ++iterations;
  }
  return iterations;
}

void Deformer::write_refined(Eigen::MatrixXd& positions) {
  expect_result_rows(positions, "write_refined");
  const Deformer& solved = base_ ? *base_ : *this;
  if (!solved.refinement_ || solved.refinement_pending_ || solved.refinement_->status().iterations == 0) return;  // none since deform()
  if (base_) {
    base_->write_refined(base_positions_);
    rebuild_from_base(positions);
    return;
  }
  const trace::Scope traced("refinement write-back", "refinement");
  update_arena_->arena.execute([&] { refinement_->write(positions); });
}

void Deformer::expect_result_rows(const Eigen::MatrixXd& positions, const char* caller) const {
  if (positions.rows() != rest_.vertex_count() || positions.cols() != 3) {
    throw std::invalid_argument(std::string(caller) + ": positions must be the " + std::to_string(rest_.vertex_count()) +
                                "×3 result of an earlier update");
  }
}

const RefinementStatus& Deformer::refinement_status() const {
  static const RefinementStatus none;
  if (base_) return base_->refinement_status();
  return refinement_ ? refinement_->status() : none;
}

const RefinementTimings& Deformer::refinement_timings() const {
  static const RefinementTimings none;
  if (base_) return base_->refinement_timings();
  return refinement_ ? refinement_->timings() : none;
}

void Deformer::set_refinement_options(const RefinementOptions& options) {
  options_.refinement = options;
  if (base_) base_->set_refinement_options(options);
  if (refinement_) refinement_->set_options(options);
}

}  // namespace hdeform
