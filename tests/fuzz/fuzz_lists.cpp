// The small text readers: vertex index lists, handle transforms, per-vertex values, Botsch–Sorkine
// labels (.sel).
#include "fuzz_input.h"
#include "hdeform/constraint_io.h"

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  const auto& path = hdeform::fuzz::write_input(data, size, ".txt");
  hdeform::fuzz::expect_clean_refusal([&] { (void)hdeform::read_vertex_indices(path, 1000); });
  hdeform::fuzz::expect_clean_refusal([&] { (void)hdeform::read_handle_transform(path); });
  hdeform::fuzz::expect_clean_refusal([&] { (void)hdeform::read_values(path, 4); });
  hdeform::fuzz::expect_clean_refusal([&] { (void)hdeform::read_vertex_labels(path, 4); });
  return 0;
}
