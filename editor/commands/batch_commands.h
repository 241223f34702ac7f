#pragma once
// The batch subcommands of `hdeform`: each registers its options on a CLI11 subcommand and
// runs when it is selected. A run returns the exit code; it throws UsageError (exit 2) for a
// wrong command line and InputError or SolveError (exit 1) for bad data.
#include "cli_fwd.h"

namespace hdeform::cli {

class BatchCommand {
 public:
  virtual ~BatchCommand() = default;
  virtual CLI::App* add_to(CLI::App& app) = 0;
  virtual int run() = 0;
};

}  // namespace hdeform::cli

#include <memory>

namespace hdeform::cli {

std::unique_ptr<BatchCommand> make_edit_command();
std::unique_ptr<BatchCommand> make_field_command();
std::unique_ptr<BatchCommand> make_bench_command();
std::unique_ptr<BatchCommand> make_transfer_command();
std::unique_ptr<BatchCommand> make_correspondence_command();
#ifdef HDEFORM_WITH_ENGINE
std::unique_ptr<BatchCommand> make_render_command();
std::unique_ptr<BatchCommand> make_gui_command();
#endif

}  // namespace hdeform::cli
