// OBJ reader, then what every command does with a mesh it has read: weights and inspection.
#include "fuzz_input.h"
#include "hdeform/laplacian.h"
#include "hdeform/mesh_check.h"
#include "hdeform/mesh_io.h"

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  const auto& path = hdeform::fuzz::write_input(data, size, ".obj");
  hdeform::fuzz::expect_clean_refusal([&] {
    const hdeform::Mesh mesh = hdeform::read_obj(path);
    const auto weights = hdeform::cotangent_weights(mesh);
    (void)hdeform::inspect_mesh(mesh, weights).warnings();
  });
  return 0;
}
