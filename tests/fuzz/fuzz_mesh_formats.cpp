// The PLY, OFF and STL readers (our own for PLY and OFF, OpenMesh's into our arrays for STL),
// then what every command does with a mesh it has read. The first byte picks the format, the rest is the file.
#include "fuzz_input.h"
#include "hdeform/laplacian.h"
#include "hdeform/mesh_check.h"
#include "hdeform/mesh_io.h"

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  if (size == 0) return 0;
  hdeform::fuzz::run_on_one_thread();
  static const char* const kNames[] = {"input.ply", "input.off", "input.stl"};
  const std::string_view content(reinterpret_cast<const char*>(data) + 1, size - 1);
  hdeform::fuzz::expect_clean_refusal([&] {
    const hdeform::Mesh mesh = hdeform::parse_mesh(kNames[data[0] % 3], content);
    const auto weights = hdeform::cotangent_weights(mesh);
    (void)hdeform::inspect_mesh(mesh, weights).warnings();
  });
  return 0;
}
