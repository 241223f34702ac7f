// hdeform: detail-preserving surface deformation (Zayer et al., Eurographics 2005).
#include <CLI/CLI.hpp>

#include <iostream>
#include <new>

#include "commands/batch_commands.h"
#include "commands/cli_support.h"
#include "commands/termination_signals.h"
#include "hdeform/errors.h"
#ifdef HDEFORM_WITH_ENGINE
#include "hdeform/engine/vulkan_context.h"
#endif

#ifdef HDEFORM_WITH_JEMALLOC
// Memory the process has not touched yet costs a fault when first written: on the 2-core virtual
// machines this project is measured on, 0.55-0.7 ms per MB for 4 KiB pages and 1.5-2.9 ms per MB
// for transparent huge pages (300 MB, four fresh processes each, 2026-12-02), and 3.3 ms per MB
// on the host of 2026-12-07. glibc hands large freed blocks straight back to the kernel, so every
// re-selection in the editor or the bench faulted its factor in again; jemalloc keeps what was
// freed for the next allocation, if told to:
// - lg_extent_max_active_fit: lavapipe bins a frame's triangles into blocks of about 80 KB (over
//   10,000 of them for a frame of the 3.3M Buddha) and frees them as their triangles are drawn.
//   jemalloc coalesces the freed blocks and by default will not split a free range more than 64
//   times the request, so each frame's blocks came from fresh pages: a frame of the 3.3M Buddha
//   took 0.87-1.22 s (`bench --render`, median), of the Buddha 61-107 ms. Allowing 2^16 times
//   the request serves them from the last frame's memory; with the next setting too, 0.20-0.23 s
//   and 28-30 ms (the split alone: 0.45-0.64 s at 3.3M, docs/performance.md).
// - Freed pages unused for 30 s are offered back to the kernel (MADV_FREE), which takes them when
//   it needs memory; until then they count as resident. Forcing them out (muzzy_decay_ms:0, until
//   2026-12-07) left the frames 1.6 to 3 times as long, whatever the decay time, because a
//   frame reuses its memory in bursts; offering them raises the peak of `bench --subdivide 1`
//   (two 822K-triangle deformers during re-selection) from 1.08 to 1.18 GB. Keeping them for good
//   (no decay) raised it from 1.27 to 1.69 GB (2026-12-02).
// - Huge pages are left to the system's setting: asking for them (thp:always, until 2026-12-02)
//   made opening the Buddha 515-618 ms against 268-334 ms without, for 10-20 ms more in a
//   factorization that reuses memory (on the host of 2026-12-07 the other way round: opening the
//   3.3M Buddha 5.0 s with them against 7.5 s; MALLOC_CONF=thp:always is the user's switch,
//   docs/performance.md "First writes").
extern "C" {
// NOLINTNEXTLINE: jemalloc reads this global by name at start-up.
const char* malloc_conf = "metadata_thp:auto,dirty_decay_ms:30000,muzzy_decay_ms:-1,lg_extent_max_active_fit:16";
}
#endif

namespace {

constexpr int kExitBadData = 1;
constexpr int kExitUsage = 2;
constexpr int kExitInternal = 3;  // an exception no check anticipated: a bug to report

}  // namespace

int main(int argc, char** argv) {
  using namespace hdeform;
  cli::watch_termination_signals();  // before any thread starts
  CLI::App app{"hdeform: harmonic-guided surface deformation (Zayer, Rössl, Karni, Seidel 2005)"};
  app.require_subcommand(1);
  app.set_version_flag("--version", "hdeform 0.1.0");

  std::vector<std::pair<CLI::App*, std::unique_ptr<cli::BatchCommand>>> commands;
  for (auto make : {cli::make_edit_command, cli::make_field_command, cli::make_transfer_command, cli::make_correspondence_command,
                    cli::make_bench_command,
#ifdef HDEFORM_WITH_ENGINE
                    cli::make_render_command, cli::make_gui_command,
#endif
                   }) {
    auto command = make();
    CLI::App* sub = command->add_to(app);
    commands.emplace_back(sub, std::move(command));
  }

  try {
    app.parse(argc, argv);
  } catch (const CLI::CallForHelp& help) {
    return app.exit(help);
  } catch (const CLI::CallForVersion& version) {
    return app.exit(version);
  } catch (const CLI::ParseError& error) {
    app.exit(error);
    return kExitUsage;
  }

  try {
    for (auto& [sub, command] : commands) {
      if (sub->parsed()) return command->run();
    }
  } catch (const cli::UsageError& error) {
    std::cerr << "hdeform: usage error: " << error.what() << "\n(see hdeform --help)\n";
    return kExitUsage;
  } catch (const InputError& error) {
    std::cerr << "hdeform: error: " << error.what() << '\n';
    return kExitBadData;
  } catch (const SolveError& error) {
    std::cerr << "hdeform: error: " << error.what() << '\n';
    return kExitBadData;
#ifdef HDEFORM_WITH_ENGINE
  } catch (const engine::RenderError& error) {
    std::cerr << "hdeform: error: " << error.what() << '\n';
    return kExitBadData;
#endif
  } catch (const std::bad_alloc&) {
    std::cerr << "hdeform: error: out of memory\n";
    return kExitBadData;
  } catch (const std::exception& error) {
    std::cerr << "hdeform: internal error: " << error.what() << " (please report it)\n";
    return kExitInternal;
  }
  return kExitUsage;
}
