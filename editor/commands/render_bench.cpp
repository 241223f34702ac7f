#include "render_bench.h"

#include <time.h>

#include <atomic>
#include <cmath>
#include <chrono>
#include <nlohmann/json.hpp>
#include <thread>

#include "cli_support.h"
#include "hdeform/deformer.h"
#include "hdeform/engine/frame_slots.h"
#include "hdeform/engine/geometry_exchange.h"
#include "hdeform/engine/mesh_renderer.h"
#include "model/mesh_picker.h"
#include "model/selection.h"
#include "render_support.h"
#include "hdeform/stopwatch.h"

namespace hdeform::cli {
namespace {

using Clock = std::chrono::steady_clock;

// Processor time of the whole process (all threads, the driver's included), milliseconds. Less
// sensitive than wall time to other tenants of a shared machine.
double process_cpu_ms() {
  timespec time{};
  clock_gettime(CLOCK_PROCESS_CPUTIME_ID, &time);
  return static_cast<double>(time.tv_sec) * 1e3 + static_cast<double>(time.tv_nsec) * 1e-6;
}

}  // namespace

nlohmann::json bench_rendering(const Mesh& mesh, const EditConstraints& constraints, const HandleTransform& transform,
                               const RenderBenchOptions& options) {
  if (options.frames < 10) throw UsageError("--frames must be at least 10");
  PictureOptions picture;
  picture.size = options.size;
  picture.device = options.device;
  picture.validation = options.validation;
  picture.quiet = options.quiet;
  const engine::VulkanContext context(picture.context());
  picture.samples = options.samples > 0 ? options.samples : context.interactive_samples();
  const engine::Bounds bounds = engine::Bounds::of(mesh.positions);
  const engine::Shot shot = picture.shot(bounds);

  Deformer deformer(mesh, constraints);
  const Eigen::VectorXf field = deformer.field().cast<float>();
  const auto classes = vertex_classes(deformer.partition());

  engine::OffscreenTarget target(context, shot.width, shot.height, shot.samples);
  engine::FrameSlots slots(context);
  engine::MeshRenderer renderer(context, target.render_pass(), target.format(), slots.count());
  engine::GeometryExchange exchange(static_cast<std::size_t>(mesh.vertex_count()));
  engine::GeometryPublisher publisher(exchange, mesh.triangles);
  publisher.publish(mesh.positions);
  renderer.set_mesh(mesh.triangles, exchange, bounds, engine::UpAxis::Z);
  renderer.set_field({field.data(), static_cast<std::size_t>(field.size())});
  renderer.set_classes(classes);
  const auto camera = engine::Camera::three_quarter_front(bounds, engine::UpAxis::Z, static_cast<float>(shot.width) / static_cast<float>(shot.height));

  // Frame cadence: the interval between successive frames' start, once a slot is free again.
  auto run_frames = [&](int count) {
    std::vector<double> intervals;
    auto previous = Clock::now();
    for (int k = 0; k < count; ++k) {
      engine::FrameSlots::Slot& slot = slots.begin();
      const auto now = Clock::now();
      if (k >= static_cast<int>(slots.count())) intervals.push_back(milliseconds_between(previous, now));
      previous = now;
      renderer.prepare(slot.index, camera, shot.settings, target.extent());
      target.begin(slot.commands);
      renderer.record(slot.commands, slot.index, target.extent());
      target.end(slot.commands);
      slots.submit(slot);
    }
    slots.wait_all();
    return summarize(intervals);
  };

  // Publishing: positions → floats and normals → one atomic swap.
  Eigen::MatrixXd moved = mesh.positions;
  deformer.deform(std::span(&transform, 1), moved);
  std::vector<double> publish_ms;
  for (int k = 0; k < 40; ++k) {
    const auto start = Clock::now();
    publisher.publish(k % 2 == 0 ? moved : mesh.positions);
    publish_ms.push_back(milliseconds_since(start));
  }

  run_frames(5);  // warm-up
  const double cpu_start = process_cpu_ms();
  const auto still_start = Clock::now();
  const Summary still = run_frames(options.frames);
  // With frames in flight one interval may be short and the next long; the whole run's wall time
  // per frame is the rate the device draws at.
  const double wall_per_frame = milliseconds_since(still_start) / options.frames;
  const double cpu_per_frame = (process_cpu_ms() - cpu_start) / options.frames;

  // The same while a solver thread drags the handle back and forth and publishes every update.
  std::atomic<bool> stop{false};
  std::atomic<int> updates{0};
  std::thread solver([&] {
    Eigen::MatrixXd positions;
    for (int step = 0; !stop.load(); ++step) {
      const double fraction = 0.5 + 0.5 * std::sin(0.1 * step);
      const HandleTransform partial = transform.at_fraction(fraction);
      deformer.deform(std::span(&partial, 1), positions);
      publisher.publish(positions);
      ++updates;
    }
  });
  const auto drag_start = Clock::now();
  const Summary dragging = run_frames(options.frames);
  const double drag_seconds = seconds_since(drag_start);
  stop = true;
  solver.join();

  // Picking as the editor does it: the BVH built once, refitted after a drag, and one ray per
  // pixel of a 64×36 grid over the view (rays that miss the mesh included), then a brush of 3%
  // of the diagonal around each hit.
  const auto& snapshot = *exchange.acquire();
  auto start = Clock::now();
  MeshPicker picker(mesh.triangles, snapshot.position_normal);
  const double pick_build_ms = milliseconds_since(start);
  start = Clock::now();
  picker.refit(snapshot.position_normal);
  const double pick_refit_ms = milliseconds_since(start);
  std::vector<double> pick_ms;
  std::vector<double> brush_ms;
  int hits = 0;
  const float brush_radius = 0.03f * 2.0f * bounds.radius();
  for (int row = 0; row < 36; ++row) {
    for (int column = 0; column < 64; ++column) {
      const auto ray = camera.ray((column + 0.5f) * static_cast<float>(shot.width) / 64.0f, (row + 0.5f) * static_cast<float>(shot.height) / 36.0f,
                                  static_cast<float>(shot.width), static_cast<float>(shot.height));
      start = Clock::now();
      const auto hit = picker.pick(ray);
      pick_ms.push_back(milliseconds_since(start));
      if (!hit) continue;
      ++hits;
      start = Clock::now();
      const auto brushed = vertices_in_ball(snapshot.position_normal, hit->point, brush_radius);
      brush_ms.push_back(milliseconds_since(start));
    }
  }

  return {{"device", context.device_name()},
          {"allocator", allocator_name()},
          {"allocator_settings", allocator_settings()},
          {"width", shot.width},
          {"height", shot.height},
          {"samples", static_cast<int>(target.format().samples)},
          {"frames", options.frames},
          {"frame_ms", to_json(still)},
          {"frame_wall_ms", std::round(wall_per_frame * 1000.0) / 1000.0},
          {"frame_cpu_ms", std::round(cpu_per_frame * 1000.0) / 1000.0},
          {"frame_ms_while_dragging", to_json(dragging)},
          {"solver_updates_per_second_while_rendering", updates.load() / drag_seconds},
          {"publish_ms", to_json(summarize(publish_ms))},
          {"pick", {{"bvh_build_ms", pick_build_ms},
                    {"bvh_refit_ms", pick_refit_ms},
                    {"rays", pick_ms.size()},
                    {"hits", hits},
                    {"pick_ms", to_json(summarize(pick_ms))},
                    {"brush_ms", to_json(summarize(brush_ms))}}},
          {"validation_messages", context.validation_message_count()}};
}

}  // namespace hdeform::cli
