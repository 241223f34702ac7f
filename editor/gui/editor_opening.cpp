// The editor window: a mesh's way from its file to the screen. A load (reading, replaying the
// session, the scene's CPU-side parts) runs on a thread of its own; its renderer's buffers are
// written on another (staged_) before the frame that installs the mesh; then the proxy for drags.
#include "gui/editor_app_parts.h"

#include "hdeform/engine/closed_mesh.h"

namespace hdeform::cli::gui {

void EditorApp::retire_document() {
  if (!document_) return;
  document_->close();
  // A set-up in progress stops only at its next stage: seconds at scan resolution (the 3.3M
  // Buddha's order of every vertex is one stage of 15 s), which the next mesh need not wait for.
  retiring_.start("Closing " + std::filesystem::path(mesh_name_).filename().string(), [document = std::move(document_)]() mutable {
    document.reset();
    return true;
  });
}

void EditorApp::finish_load() {
  if (staged_ && stage_.done()) {
    auto outcome = stage_.take();
    Staged staged = std::move(*staged_);
    staged_.reset();
    if (!outcome.error.empty()) report_open_failure("Cannot draw " + std::filesystem::path(staged.loaded.session.mesh).filename().string() + ": " + outcome.error);
    else if (outcome.result && *outcome.result) install_with_problem(std::move(staged.loaded), std::move(staged.buffers));
  }
  if (!load_.done()) return;
  const bool progress_shown = load_.seconds() > kProgressDelay;
  auto outcome = load_.take();
  if (!outcome.error.empty()) {
    report_open_failure(outcome.error);
    return;
  }
  stage(std::move(*outcome.result), progress_shown);
}

void EditorApp::report_open_failure(const std::string& failure) {
  error_message_ = failure;
  open_failure_ = failure;
  if (!after_open_note_.empty()) status_ = after_open_note_;
  after_open_note_.clear();
  print_json_line({{"event", "error"}, {"message", failure}});
  if (!document_ && (options_.benchmark_drag_seconds > 0.0)) {
    std::cerr << "hdeform: error: " << failure << '\n';
    exit_code_ = 1;
    quit_ = true;
  }
}

void EditorApp::stage(Loaded loaded, bool announced) {
  const Mesh& rest = loaded.document->rest();
  const std::string name = std::filesystem::path(loaded.session.mesh).filename().string();
  std::unique_ptr<engine::MeshBuffers> buffers;
  try {
    buffers = std::make_unique<engine::MeshBuffers>(*context_, static_cast<std::size_t>(rest.vertex_count()),
                                                    static_cast<std::size_t>(rest.triangle_count()), renderer_->frame_count());
  } catch (const engine::RenderError& error) {
    report_open_failure("Cannot draw " + name + ": " + error.what());
    return;
  }
  // The rest shape the load published, written into every frame's geometry: the first frame
  // takes the same snapshot and uploads nothing.
  const engine::GeometrySnapshot* snapshot = loaded.scene.exchange->acquire();
  staged_.emplace(Staged{std::move(loaded), std::move(buffers), announced});
  stage_.start("Preparing to draw " + name,
               [buffers = staged_->buffers.get(), rest = staged_->loaded.document->shared_rest(), snapshot, stop = staged_->stop, done = staged_->done] {
                 const trace::Scope traced("the renderer's buffers written", "set-up");
                 return buffers->fill(rest->triangles, snapshot, [&](double share) {
                   done->store(share);
                   return !stop->load();
                 });
               },
               [] { glfwPostEmptyEvent(); });
}

void EditorApp::drop_staged() {
  if (!staged_) return;
  staged_->stop->store(true);
  stage_.finish();  // the buffers are written until the current piece ends (milliseconds)
  staged_.reset();  // and destroyed here, where Vulkan is called
}

void EditorApp::install_with_problem(Loaded loaded, std::unique_ptr<engine::MeshBuffers> buffers) {
  const std::string problem = loaded.problem;
  install(std::move(loaded), std::move(buffers));
  if (!problem.empty()) {
    open_failure_ = problem;
    error_message_ = problem;
    print_json_line({{"event", "error"}, {"message", problem}});
  }
}

void EditorApp::install(Loaded loaded_document, std::unique_ptr<engine::MeshBuffers> buffers) {
  const trace::Scope traced("mesh installed", "frame");
  Loaded* loaded = &loaded_document;
  vkDeviceWaitIdle(context_->device());
  retire_document();  // its pipeline stops before its publisher goes
  confirm_exact_.reset();  // a question about the mesh let go of
  publisher_.reset();
  const Mesh& rest = loaded->document->rest();
  exchange_ = std::move(loaded->scene.exchange);
  publisher_ = std::move(loaded->scene.publisher);
  // Unless those kept from an earlier mesh are larger: their pages are written already.
  if (loaded->scene.view_classes.capacity() > view_classes_.capacity()) std::swap(view_classes_, loaded->scene.view_classes);
  if (loaded->scene.view_field.capacity() > view_field_.capacity()) std::swap(view_field_, loaded->scene.view_field);
  loaded->document->set_publish([this](const Eigen::MatrixXd& positions, std::uint64_t request, Document::Answer answer) {
    // A partial answer is sure only on the proxy's vertices: those alone are handed over. A
    // settling shape is drawn as the proxy (a new solve is motion) until the next replaces it, so
    // only the proxy's normals are worked out; every position goes over, to pick and paint on.
    using Detail = engine::GeometryPublisher::Detail;
    publisher_->publish(positions, request,
                        answer == Document::Answer::Partial    ? Detail::Proxy
                        : answer == Document::Answer::Settling ? Detail::ProxyNormals
                                                               : Detail::Whole);
  });
  // The window wakes once the publication's state is recorded too: a frame then knows whether the
  // shape it shows is the final one (view_motion).
  loaded->document->set_wake([] { glfwPostEmptyEvent(); });
  document_ = std::move(loaded->document);
  announced_refinement_ = announced_failure_ = 0;  // its requests count from 1 again
  scene_size_of_ = nullptr;  // another mesh, perhaps where the last one was in memory
  mesh_name_ = loaded->session.mesh;
  const engine::Bounds bounds = loaded->scene.bounds;
  up_axis_ = chosen_up_axis().value_or(engine::UpAxis::Z);
  renderer_->set_mesh(std::move(buffers), *exchange_, bounds, up_axis(), loaded->scene.closed);
  // The last mesh's picture does not stand for this one while its first picture is drawn.
  target_->drop_scene();
  start_proxy();
  picker_.reset();
  adjust_camera(true);
  brush_radius_ = 0.03f * bounds.radius() * 2.0f;
  view_dirty_ = true;
  shown_tag_ = 0;
  output_path_ = options_.output.empty() ? default_output_path() : options_.output;
  glfwSetWindowTitle(window_, ("hdeform — " + mesh_name_).c_str());
  if (recent_ && !names_builtin_shape(last_open_request_) && !last_open_request_.empty() && std::filesystem::exists(last_open_request_)) {
    recent_->add(std::filesystem::absolute(last_open_request_).lexically_normal().string());
  }
  status_ = "Opened " + std::filesystem::path(mesh_name_).filename().string();
  if (!after_open_note_.empty()) status_ += ". " + after_open_note_;
  after_open_note_.clear();
  error_message_.clear();
  print_json_line({{"event", "opened"},
                   {"mesh", mesh_name_},
                   {"vertices", rest.vertex_count()},
                   {"triangles", rest.triangle_count()},
                   {"session_digest", loaded->session_digest}});
  document_->request_update();
  post_recovery();
}

EditorApp::PreparedScene EditorApp::prepare_scene(const std::shared_ptr<const Mesh>& shared_rest) {
  const Mesh& rest = *shared_rest;
  PreparedScene scene;
  scene.exchange = std::make_unique<engine::GeometryExchange>(static_cast<std::size_t>(rest.vertex_count()));
  // The publisher shares the document's triangles (at 13 million triangles a copy is 158 MB).
  scene.publisher = std::make_unique<engine::GeometryPublisher>(*scene.exchange, std::shared_ptr<const Eigen::MatrixXi>(shared_rest, &rest.triangles));
  scene.publisher->publish(rest.positions, 0);
  scene.bounds = engine::Bounds::of(rest.positions);
  scene.closed = engine::every_edge_has_its_reverse(rest.triangles, rest.vertex_count());
  scene.view_classes.assign(static_cast<std::size_t>(rest.vertex_count()), HD_CLASS_FREE);
  scene.view_field.assign(static_cast<std::size_t>(rest.vertex_count()), 0.0f);
  return scene;
}

void EditorApp::start_proxy() {
  motion_detail_.enable(false);
  proxy_task_.abandon();
  if (options_.proxy != "auto" || !context_->is_cpu_device()) return;
  const Mesh& rest = document_->rest();
  if (rest.triangle_count() <= 2 * engine::kProxyTriangles) return;
  // The document's rest shape, shared: copying it here took the frame 0.5 s at 3.3M triangles.
  proxy_task_.start("Simplifying the mesh for dragging", [rest = document_->shared_rest()] {
    const trace::Scope traced("proxy mesh", "set-up");
    return engine::proxy_triangles(rest->triangles, rest->positions);
  }, [] { glfwPostEmptyEvent(); });
}

void EditorApp::finish_proxy() {
  if (!proxy_task_.done()) return;
  auto outcome = proxy_task_.take();
  if (!outcome.result) {
    // Only slower frames follow: say so, and draw the whole mesh as always.
    status_ = "No simplified mesh for dragging: " + outcome.error;
    return;
  }
  renderer_->set_proxy(*outcome.result);
  publisher_->set_proxy(*outcome.result);
  document_->set_partial_vertices(publisher_->proxy_vertices());  // what a drag's answer needs
  proxy_triangle_count_ = outcome.result->rows();
  motion_detail_.enable(renderer_->has_proxy());
  print_json_line({{"event", "proxy"}, {"triangles", outcome.result->rows()}});
}

}  // namespace hdeform::cli::gui
