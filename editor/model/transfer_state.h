#pragma once
// What the editor's transfer mode holds, for its recovery file: the files it opened, the marker
// pairs as placed (saved or not), each view's up axis and the transfer's settings.
#include <filesystem>
#include <string>
#include <vector>

#include "hdeform/marker_io.h"

namespace hdeform::cli {

struct TransferState {
  std::string source_rest;
  std::string target;
  std::vector<std::string> poses;  // the pose files, one each (patterns already expanded)
  std::string markers_file;        // where Save writes ("": none yet)
  int source_column = 1;
  MarkerPairs markers;
  bool source_y_up = false;
  bool target_y_up = false;
  int method = 0;  // 0 correspondence, 1 interpolation
  int top_n = 0;
  double mismatch_threshold = 0.2;

  bool operator==(const TransferState& other) const;
};

// Written atomically. Reading checks every field and names the file and the field when one is
// wrong (InputError); the marker indices are checked against the meshes when they are loaded.
void write_transfer_state(const std::filesystem::path& path, const TransferState& state);
TransferState read_transfer_state(const std::filesystem::path& path);

// "horse-ref.obj -> camel-ref.obj, 48 poses, 124 marker pairs", for the restore prompt.
std::string describe_transfer_state(const TransferState& state);

}  // namespace hdeform::cli
