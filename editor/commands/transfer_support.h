#pragma once
// What `hdeform transfer` and `hdeform correspondence` share: the source and target meshes, the
// marker pairs and the method's options.
#include "cli_fwd.h"
#include <nlohmann/json_fwd.hpp>

#include <string>

#include "cli_support.h"
#include "hdeform/marker_io.h"
#include "hdeform/mesh.h"
#include "hdeform/transfer.h"

namespace hdeform::cli {

struct TransferArguments {
  std::string source_rest;
  std::string target;
  std::string markers;
  int source_column = 1;  // which column of the marker file holds the source's vertices
  std::string method = "correspondence";
  int top_n = 0;
  double mismatch_threshold = kDefaultMismatchThreshold;

  // --source-rest, --target, --markers, --source-column, --top-n, --mismatch-threshold, and
  // --method when `with_method`.
  void add_options(CLI::App& command, bool with_method);
  std::vector<std::string> inputs() const { return {source_rest, target, markers}; }
  // Throws UsageError for an unknown method or column.
  TransferOptions options(SolverBackend backend, FactorPrecision precision) const;
};

struct TransferInputs {
  Mesh source_rest;
  Mesh target;
  MarkerPairs markers;
};
TransferInputs load_transfer_inputs(const TransferArguments& arguments, const Progress& progress);

// Counts and set-up figures of a prepared transfer, for the JSON report.
nlohmann::json describe_setup(const DeformationTransfer& transfer);

}  // namespace hdeform::cli
