#pragma once
/// @file
/// Runs Deformer updates off the caller's thread (the editor's render thread never solves).
/// When transforms arrive faster than updates finish, the newest wins: a request replaces the
/// one still waiting instead of queueing behind it, so the result on screen is never stale by
/// more than the update in flight.
///
/// The updates run on a thread of the pipeline's own, not on a TBB worker: a worker driving the
/// update would be one of the P-1 workers TBB starts, leaving its parallel stages one thread
/// fewer (on 2 cores, none to help).
///
/// With refinement on, the thread answers each request with the paper's update first and then,
/// while no newer request waits, runs as-rigid-as-possible iterations one at a time, publishing
/// each, until they converge; a new request takes over after the iteration in flight.
///
/// A request may ask for some vertices only (the editor's drag, drawing a proxy over them): on a
/// base (multiresolution) only they are rebuilt, and the answer is published marked partial.
/// Once no request waits and the refinement's delay has passed, the thread rebuilds every vertex
/// (Deformer::complete; nothing to do for an exact solve) and publishes the answer whole before
/// anything else; wait_idle() and settled_positions() wait for that too, so what they give is
/// always whole.
///
/// An update or iteration that throws (out of memory, say) ends the work for its request: the
/// failure callback says so, and a new request is answered as usual.
#include <Eigen/Core>
#include <chrono>
#include <condition_variable>
#include <cstdint>
#include <exception>
#include <functional>
#include <memory>
#include <mutex>
#include <span>
#include <thread>
#include <vector>

#include "hdeform/deformer.h"

namespace hdeform {

/// Runs a Deformer's updates on a thread of its own: the newest request wins, the paper's update
/// is published first, then refinement iterations while no newer request waits.
class UpdatePipeline {
 public:
  /// What the publish callback receives: the positions and what they answer.
  struct Result {
    const Eigen::MatrixXd& positions;
    std::uint64_t request;  ///< the number submit() returned for these transforms
    double update_ms;       ///< the paper's update, or the refinement iteration
    /// Refinement iterations in these positions (0: the paper's update) and where they stand.
    RefinementStatus refinement;
    /// An answer to a request for some vertices (submit()'s `only_vertices`): only those are sure
    /// to hold it (on a base, the others hold an earlier answer's).
    bool partial = false;
    /// The rows a partial answer left, rebuilt: the same request's update made whole.
    bool completion = false;
  };
  /// Called on a worker thread after each finished update; must not block for long.
  using Publish = std::function<void(const Result&)>;
  /// What the failure callback receives: the request whose answer failed, and why. Nothing more
  /// comes for that request: what was published for it stays the last answer to it.
  struct Failure {
    std::uint64_t request;
    std::exception_ptr error;
    /// Whether the refinement failed (its set-up, an iteration or the publication of one): the
    /// paper's update of the request was published before. Otherwise the update itself failed
    /// (or its publication), and the last answer published is an earlier request's.
    bool refining;
  };
  /// Called on the pipeline's thread after a failure is recorded (last_error()), before
  /// wait_idle() returns; must not throw.
  using Fail = std::function<void(const Failure&)>;

  /// Keeps references to all three; the deformer must outlive the pipeline.
  UpdatePipeline(Deformer& deformer, Publish publish, Fail fail = {});
  ~UpdatePipeline();  ///< finishes the update in flight; a request still waiting is dropped
  UpdatePipeline(const UpdatePipeline&) = delete;
  UpdatePipeline& operator=(const UpdatePipeline&) = delete;

  /// Posts transforms (one per handle); returns at once with the request's number. With
  /// `only_vertices`, the answer need hold only those vertices (Deformer::deform_vertices).
  std::uint64_t submit(std::span<const HandleTransform> transforms, std::shared_ptr<const std::vector<int>> only_vertices = {});
  /// Blocks until no update is waiting or running and the refinement, when on, has converged.
  void wait_idle();
  /// ... and then the positions last published: the final answer to the last request.
  Eigen::MatrixXd settled_positions();
  /// Refinement after each update (off at first). Turning it on refines the last result.
  void set_refinement(bool on);
  /// Whether refinement is on.
  bool refinement() const;
  /// Refinement starts only once no request has come for this long (0 at first). On a CPU device,
  /// where iterations would take the cores the rasterizer needs, the editor waits for the input to
  /// rest, so that a drag is answered as fast as without refinement.
  void set_refinement_delay(std::chrono::milliseconds delay);
  /// Refinement iterations are published at most this often (0 at first: each); the last of a run
  /// (converged, or at the cap) always is. On a CPU device every publication is a frame drawn on
  /// the cores the iterations need.
  void set_refinement_publication_interval(std::chrono::milliseconds interval);

  /// The number of updates finished so far.
  std::uint64_t finished_updates() const;
  std::uint64_t superseded_requests() const;  ///< replaced by a newer one before they started
  /// The failure of the latest update that threw (the previous result stays published), or null.
  std::exception_ptr last_error() const;

 private:
  void run();
  bool wants_refinement() const;  ///< with the lock held
  bool has_work() const;          ///< with the lock held

  Deformer& deformer_;
  Publish publish_;
  Fail fail_;
  mutable std::mutex mutex_;
  std::condition_variable idle_;
  std::condition_variable wake_;
  std::vector<HandleTransform> pending_;
  std::vector<HandleTransform> current_;
  bool has_pending_ = false;
  std::shared_ptr<const std::vector<int>> pending_only_;  ///< the waiting request's vertices (null: all)
  std::shared_ptr<const std::vector<int>> current_only_;
  bool whole_ = true;  ///< positions_ hold every vertex of the last answer
  bool busy_ = true;  ///< the thread is answering a request or refining, or copying the rest positions at its start (the lock is not held meanwhile)
  bool refine_ = false;
  bool refined_out_ = true;  ///< the last result needs no more iterations (converged, or no refinement)
  bool has_result_ = false;  ///< a request has been answered: there is something to refine
  bool stopping_ = false;
  std::uint64_t submitted_ = 0;
  std::uint64_t pending_request_ = 0;
  std::uint64_t answered_request_ = 0;  ///< the request the published positions answer
  std::chrono::steady_clock::time_point last_submit_{};
  std::chrono::milliseconds refinement_delay_{0};
  std::chrono::milliseconds publication_interval_{0};
  std::chrono::steady_clock::time_point last_publication_{};
  std::uint64_t finished_ = 0;
  std::uint64_t superseded_ = 0;
  std::exception_ptr error_;
  Eigen::MatrixXd positions_;
  bool refined_unwritten_ = false;  ///< iterations ran that positions_ do not show yet (the pipeline's thread only)
  std::thread thread_;  ///< last: starts once every member above exists
};

}  // namespace hdeform
