#pragma once
// The whole editing state, as the editor keeps it and as JSON on disk: the mesh, the stages
// already applied (made the new rest shape), and the current stage — region of interest, fixed
// vertices, handles with their transforms. `hdeform edit --session` replays it in batch and gets
// the editor's mesh exactly: the same Deformer with the same inputs gives the same bits.
#include <Eigen/Core>
#include <filesystem>
#include <functional>
#include <optional>
#include <nlohmann/json_fwd.hpp>
#include <string>
#include <vector>

#include "hdeform/constraints.h"
#include "hdeform/deformer.h"
#include "hdeform/handle_transform.h"
#include "hdeform/mesh.h"

namespace hdeform::cli {

struct SessionHandle {
  std::vector<int> vertices;
  HandleTransform transform;
};

struct EditStage {
  std::vector<int> region_of_interest;  // empty: the whole mesh
  std::vector<int> fixed;
  std::vector<SessionHandle> handles;
  bool refine = false;  // as-rigid-as-possible refinement after the paper's update (see stage_result)
  // Its settle test (RefinementOptions::settle): kEditorSettle in sessions the editor writes, 0
  // (the energy test alone, as `edit --refine auto`) where absent.
  double refine_settle = 0.0;

  EditConstraints constraints() const;
  std::vector<HandleTransform> transforms() const;
  // Where its refinement stops: the default RefinementOptions with refine_settle.
  RefinementOptions refinement_options() const;
  bool operator==(const EditStage& other) const;
};

struct Session {
  // An OBJ path (relative paths are relative to the session file's folder when read), or
  // "shape:NAME" / "shape:NAME:RESOLUTION" for a built-in shape.
  std::string mesh;
  std::vector<EditStage> applied;
  EditStage current;
  int active_handle = 0;
  // Where the editor solved (Deformer::resolution): Exact or Multiresolution on a base of
  // base_vertices, so that a replay solves alike. Automatic (decided by the mesh's size when
  // opened or replayed) in a session the editor has not opened yet; "exact" where a file has none
  // (written before multiresolution).
  Resolution resolution = Resolution::Automatic;
  Eigen::Index base_vertices = kDefaultBaseVertices;
  // How the editor stored its factors (SparseCholesky::factor): written when single, so that a
  // replay solves alike; absent, the opener's choice (double unless asked).
  std::optional<FactorPrecision> precision = std::nullopt;

  bool operator==(const Session& other) const;
};

nlohmann::json to_json(const Session& session);
// A short fingerprint of the state (of its JSON), equal for equal sessions: the editor announces
// the digest of every state it puts in the recovery file, so that a test can tell whether a
// restored state is one the user had.
std::string session_digest(const Session& session);
// ... and of positions, bit for bit: the editor names the shape it shows and the one it saves.
std::string positions_digest(const Eigen::MatrixXd& positions);

// Where a session came from, to name the line of a problem found after parsing.
struct SessionSource {
  std::filesystem::path path;
  std::string text;
  // "<file>:<line>" for a JSON pointer ("<file>" when not found).
  std::string where(const std::string& pointer) const;
};

// Parses and checks the structure (types, finite numbers, valid transforms). Throws InputError
// "<file>:<line>: <problem>". The mesh path is resolved against the session file's folder.
Session read_session(const std::filesystem::path& path, SessionSource* source = nullptr);
Session session_from_json(const nlohmann::json& json, const SessionSource& source);
// Written atomically.
void write_session(const std::filesystem::path& path, const Session& session);

// Checks every vertex index against the mesh, repeated vertices in one list, and vertices that
// are both fixed and in a handle or in two handles; errors name the line.
void check_session_against_mesh(const Session& session, Eigen::Index vertex_count, const SessionSource& source);

// The session's base mesh (an OBJ, or a built-in shape). With `source`, a problem also names the
// session file's line, and the session's vertex lists are checked against the mesh
// (check_session_against_mesh), so that a list that does not fit names its line too.
Mesh load_session_mesh(const Session& session, const SessionSource* source = nullptr);

// A stage's result as every saved or applied mesh is computed, in the editor and by `hdeform edit
// --session` alike: the paper's update for the stage's transforms and, when the stage refines,
// refinement iterations from the paper's result until they converge with the stage's
// refinement_options(). The same bits wherever it runs, whatever the deformer did before.
// `deformer` must have the stage's mesh and constraints.
Eigen::MatrixXd stage_result(Deformer& deformer, const EditStage& stage);

// The rest shape after the applied stages, then the current stage's result (the rest shape
// itself when the current stage has no handle), solved where the session says (its resolution
// and base_vertices replace options'). `progress` as for Deformer.
Eigen::MatrixXd replay_session(const Session& session, const Mesh& base, const DeformerOptions& options,
                               const ProgressCallback& progress = {});

}  // namespace hdeform::cli
