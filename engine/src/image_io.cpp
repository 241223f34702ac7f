#include "hdeform/engine/image_io.h"

#include <stb_image.h>
#include <stb_image_write.h>

#include <string>

#include "hdeform/atomic_file.h"
#include "hdeform/errors.h"

namespace hdeform::engine {

void write_png(const std::filesystem::path& path, const Pixels& pixels) {
  std::string encoded;
  const int ok = stbi_write_png_to_func(
      [](void* context, void* data, int size) { static_cast<std::string*>(context)->append(static_cast<const char*>(data), static_cast<std::size_t>(size)); },
      &encoded, static_cast<int>(pixels.width), static_cast<int>(pixels.height), 4, pixels.rgba.data(), static_cast<int>(pixels.width) * 4);
  if (!ok) throw InputError(path.string() + ": PNG encoding failed");
  write_file_atomically(path, [&](std::ostream& out) { out.write(encoded.data(), static_cast<std::streamsize>(encoded.size())); });
}

Pixels read_png(const std::filesystem::path& path) {
  int width = 0, height = 0, channels = 0;
  unsigned char* data = stbi_load(path.c_str(), &width, &height, &channels, 4);
  if (data == nullptr) throw InputError(path.string() + ": not a readable image (" + stbi_failure_reason() + ")");
  Pixels pixels{static_cast<uint32_t>(width), static_cast<uint32_t>(height), std::vector<uint8_t>(data, data + std::size_t(width) * height * 4)};
  stbi_image_free(data);
  return pixels;
}

}  // namespace hdeform::engine
