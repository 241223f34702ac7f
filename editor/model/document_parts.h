#pragma once
// What the Document keeps of its work on other threads, for document.cpp and document_solver.cpp:
// the set-up being built, and the vertex adjacency.
#include <atomic>
#include <memory>
#include <mutex>
#include <string>

#include "background_task.h"
#include "document.h"

namespace hdeform::cli {

struct Document::Build {
  EditConstraints constraints;
  std::shared_ptr<const Mesh> rest;
  SolveChoice choice;
  std::shared_ptr<const MeshOperators> operators;  // of `rest`, from the last set-up on it, or null
  // Shared with the set-up's thread, which an abandoned set-up keeps to its next stage.
  struct Progress {
    std::atomic<bool> stop{false};  // set once the set-up cannot serve: it stops at its next stage
    std::mutex mutex;
    std::string stage;  // with mutex: the set-up's current stage, for the panel
  };
  std::shared_ptr<Progress> progress = std::make_shared<Progress>();
  BackgroundTask<std::unique_ptr<Deformer>> task;
};

struct Document::AdjacencyBuild {
  BackgroundTask<VertexAdjacency> task;
};

}  // namespace hdeform::cli
