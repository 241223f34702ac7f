// Links the installed engine component: the framing the renderer's camera uses, no device needed.
#include <hdeform/engine/camera.h>
#include <hdeform/shapes.h>

#include <cstdio>

int main() {
  const auto shape = hdeform::make_shape(hdeform::ShapeKind::Cactus, 16);
  const auto bounds = hdeform::engine::Bounds::of(shape.mesh.positions);
  if (!(bounds.radius() > 0.0f)) return 1;
  std::printf("the cactus fits a sphere of radius %.3f\n", bounds.radius());
  return 0;
}
