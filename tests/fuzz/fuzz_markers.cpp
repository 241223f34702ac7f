// Marker-pair reader, against meshes of a plausible size, in both column orders.
#include "fuzz_input.h"
#include "hdeform/marker_io.h"

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  const auto& path = hdeform::fuzz::write_input(data, size, ".txt");
  for (const auto column : {hdeform::SourceColumn::First, hdeform::SourceColumn::Second}) {
    hdeform::fuzz::expect_clean_refusal([&] { (void)hdeform::read_marker_pairs(path, column, 1000, 700); });
  }
  return 0;
}
