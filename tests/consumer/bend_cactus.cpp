// Bends the cactus's arm through the installed library and checks what the method guarantees:
// the fixed vertices stay exactly at rest and the handle follows its transform.
#include <hdeform/deformer.h>
#include <hdeform/shapes.h>

#include <cstdio>

int main() {
  const auto shape = hdeform::make_shape(hdeform::ShapeKind::Cactus, 24);
  hdeform::Deformer deformer(shape.mesh, shape.demo_constraints);
  Eigen::MatrixXd positions;
  deformer.deform(std::span(&shape.demo_transform, 1), positions);
  for (const int v : shape.demo_constraints.fixed) {
    if (positions.row(v) != shape.mesh.positions.row(v)) {
      std::printf("fixed vertex %d moved\n", v);
      return 1;
    }
  }
  const int tip = shape.demo_constraints.handles[0][0];
  const Eigen::Vector3d expected = shape.demo_transform.apply(shape.mesh.positions.row(tip).transpose());
  if ((positions.row(tip).transpose() - expected).norm() > 1e-9) {
    std::printf("handle vertex %d is not where its transform puts it\n", tip);
    return 1;
  }
  std::printf("bent the cactus: %lld vertices, the fixed ones at rest\n", static_cast<long long>(positions.rows()));
  return 0;
}
