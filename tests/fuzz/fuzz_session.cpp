// Session reader, then the checks against a mesh that loading a session runs.
#include <nlohmann/json.hpp>

#include "fuzz_input.h"
#include "model/session.h"

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  const auto& path = hdeform::fuzz::write_input(data, size, ".json");
  hdeform::fuzz::expect_clean_refusal([&] {
    hdeform::cli::SessionSource source;
    const auto session = hdeform::cli::read_session(path, &source);
    hdeform::cli::check_session_against_mesh(session, 1000, source);
    for (const auto& stage : session.applied) (void)stage.constraints();
    (void)session.current.constraints();
    (void)hdeform::cli::to_json(session).dump();
  });
  return 0;
}
