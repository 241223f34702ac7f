#include "hdeform/engine/offscreen.h"

#include "hdeform/mesh.h"

namespace hdeform::engine {

Pixels render_offscreen(const VulkanContext& context, const Scene& scene, const Shot& shot) {
  validate_mesh(scene.positions, scene.triangles, "mesh to draw");
  OffscreenTarget target(context, shot.width, shot.height, shot.samples);
  MeshRenderer renderer(context, target.render_pass(), target.format(), 1);
  const Bounds bounds = scene.rest_bounds.radius() > 0.0f ? scene.rest_bounds : Bounds::of(scene.positions);
  GeometryExchange geometry(static_cast<std::size_t>(scene.positions.rows()));
  GeometryPublisher(geometry, scene.triangles).publish(scene.positions);
  renderer.set_mesh(scene.triangles, geometry, bounds, scene.up);
  if (scene.proxy_triangles.rows() > 0) renderer.set_proxy(scene.proxy_triangles);
  if (scene.field.size() > 0) {
    const Eigen::VectorXf field = scene.field.cast<float>();
    renderer.set_field({field.data(), static_cast<std::size_t>(field.size())});
  }
  renderer.set_classes(scene.classes);
  renderer.set_markers(scene.markers);
  const float aspect = static_cast<float>(shot.width) / static_cast<float>(shot.height);
  const Camera camera = shot.camera.value_or(Camera::three_quarter_front(bounds, scene.up, aspect));
  renderer.prepare(0, camera, shot.settings, target.extent());
  context.submit_and_wait([&](VkCommandBuffer commands) {
    target.begin(commands);
    renderer.record(commands, 0, target.extent());
    target.finish(commands);
  });
  return target.pixels();
}

}  // namespace hdeform::engine
