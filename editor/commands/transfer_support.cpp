#include "transfer_support.h"

#include <CLI/CLI.hpp>
#include <nlohmann/json.hpp>

#include "hdeform/mesh_io.h"

namespace hdeform::cli {

void TransferArguments::add_options(CLI::App& command, bool with_method) {
  command.add_option("--source-rest", source_rest, "Source (reference) mesh at rest (OBJ, PLY, OFF or STL)")->required();
  command.add_option("--target", target, "Target mesh (OBJ, PLY, OFF or STL)")->required();
  command.add_option("--markers", markers, "Marker pairs: two 0-based vertex indices per line")->required();
  command.add_option("--source-column", source_column, "Which column of the marker file is the source's: 1 or 2")->capture_default_str();
  if (with_method) command.add_option("--method", method, "correspondence (§6) or interpolation (§7)")->capture_default_str();
  command.add_option("--top-n", top_n, "Correspondence: compare only the N largest harmonic coordinates (3 ≤ N ≤ markers; default all)");
  command.add_option("--mismatch-threshold", mismatch_threshold,
                     "Correspondence: a target triangle whose nearest source coordinate is farther than this takes an interpolated deformation")
      ->capture_default_str();
}

TransferOptions TransferArguments::options(SolverBackend backend, FactorPrecision precision) const {
  TransferOptions options;
  const auto parsed = parse_transfer_method(method);
  if (!parsed) throw UsageError("--method must be correspondence or interpolation (got '" + method + "')");
  if (source_column != 1 && source_column != 2) throw UsageError("--source-column must be 1 or 2");
  if (top_n < 0) throw UsageError("--top-n must be positive");
  if (*parsed == TransferMethod::Interpolation && top_n != 0) throw UsageError("--top-n applies to the correspondence method only");
  options.method = *parsed;
  options.top_n = top_n;
  options.mismatch_threshold = mismatch_threshold;
  options.backend = backend;
  options.precision = precision;
  return options;
}

TransferInputs load_transfer_inputs(const TransferArguments& arguments, const Progress& progress) {
  TransferInputs inputs;
  progress("reading " + arguments.source_rest);
  inputs.source_rest = read_mesh(arguments.source_rest);
  progress("reading " + arguments.target);
  inputs.target = read_mesh(arguments.target);
  inputs.markers = read_marker_pairs(arguments.markers, arguments.source_column == 1 ? SourceColumn::First : SourceColumn::Second,
                                     inputs.source_rest.vertex_count(), inputs.target.vertex_count());
  return inputs;
}

nlohmann::json describe_setup(const DeformationTransfer& transfer) {
  const auto& timings = transfer.setup_timings();
  nlohmann::json setup = {{"total", timings.total_ms}, {"reconstruction_factor", timings.reconstruction_ms}};
  if (transfer.options().method == TransferMethod::Correspondence) {
    setup["source_coordinates"] = timings.source_coordinates_ms;
    setup["target_coordinates"] = timings.target_coordinates_ms;
    setup["matching"] = timings.matching_ms;
    setup["correspondence"] = timings.source_coordinates_ms + timings.target_coordinates_ms + timings.matching_ms;
    setup["mismatch_fill"] = timings.mismatch_ms;
  } else {
    setup["marker_fields_factor"] = timings.marker_fields_ms;
  }
  nlohmann::json report = {{"method", to_string(transfer.options().method)},
                           {"markers", transfer.markers().size()},
                           {"source", {{"vertices", transfer.source_rest().vertex_count()}, {"triangles", transfer.source_rest().triangle_count()}}},
                           {"target", {{"vertices", transfer.target_rest().vertex_count()}, {"triangles", transfer.target_rest().triangle_count()}}},
                           {"factorizations", transfer.factorizations()},
                           {"precision", to_string(transfer.options().precision)},
                           {"single_precision_factorizations", transfer.single_precision_factorizations()},
                           {"setup_ms", setup},
                           {"warnings", transfer.warnings()}};
  if (transfer.options().method == TransferMethod::Correspondence) {
    report["top_n"] = transfer.options().top_n;
    report["mismatch_threshold"] = transfer.options().mismatch_threshold;
    report["mismatched_triangles"] = transfer.mismatch_count();
  }
  return report;
}

}  // namespace hdeform::cli
