#pragma once
// The native viewer: a GLFW window whose swapchain images receive the offscreen renderer's RGBA8
// picture by vkCmdCopyBufferToImage (no graphics pipeline: drawing points is 20-80x slower than
// compute splatting on lavapipe). Mouse: left drag orbits, right (or middle) drag pans, wheel
// zooms. Keys: 1-4 colour mode, F follow the tracked camera, Space pause, N single step,
// H help overlay, Q/Esc quit.
//
// Thread safety: GLFW requires every call on the main thread; a Viewer belongs to that thread.
// Presentation uses queue_for_worker(0) of the Context (locking its mutex), which must be able
// to present to the window (true on lavapipe, whose one family does everything; otherwise the
// constructor throws cofusion::Error saying so).
#include <Eigen/Geometry>
#include <memory>
#include <optional>
#include <string>
#include <vector>

#include "gpu/context.h"
#include "gpu/stream.h"
#include "renderer/image.h"
#include "renderer/overlay.h"
#include "renderer/view_renderer.h"

struct GLFWwindow;

namespace cofusion::renderer {

// A camera orbiting a target point: yaw about the world's up axis (-y), pitch above the horizon.
struct OrbitCamera {
  Eigen::Vector3d target_world = Eigen::Vector3d(0, 0, 1.5);
  double distance_m = 2.5;
  double yaw_rad = 0.0;    // 0: looking along +z
  double pitch_rad = 0.4;  // > 0: looking down on the target
  Eigen::Isometry3d T_world_view() const;
  void orbit(double dx_px, double dy_px);  // mouse drag, pixels
  void pan(double dx_px, double dy_px);
  void zoom(double wheel_steps);           // > 0 moves closer
};

// What the keys change; read by the caller's loop (pause, single step, quit) and by frame().
struct ViewerState {
  ColourMode colour_mode = ColourMode::Rgb;
  bool follow_camera = false;  // view from behind the tracked camera instead of the orbit
  bool paused = false;
  bool step_requested = false;  // N while paused: the caller runs one frame and clears it
  bool quit_requested = false;
  bool show_help = false;
  OrbitCamera orbit;
  // Applies one key press (GLFW key code). Returns true when the key is one of the viewer's.
  bool on_key(int glfw_key);
  // The text lines of the help overlay.
  static std::vector<std::string> help_lines();
};

struct ViewerOptions {
  int width = 960;   // window size, screen pixels
  int height = 720;
  std::string title = "cofusion";
  double fov_y_deg = 60.0;  // the virtual camera's vertical field of view
};

class Viewer {
 public:
  // Initialises GLFW (throws cofusion::Error when there is no display) and adds the instance and
  // device extensions a window needs to `options`; call before creating the Context.
  static void add_required_extensions(gpu::ContextOptions& options);

  Viewer(gpu::Context& ctx, const ViewerOptions& options = {});
  ~Viewer();
  Viewer(const Viewer&) = delete;
  Viewer& operator=(const Viewer&) = delete;

  // Handles window events (keys, mouse); false once the window should close (Q, Esc, close box).
  bool poll();
  ViewerState& state() { return state_; }
  const ViewerState& state() const { return state_; }

  // The virtual camera for the window's current size: the orbit, or with follow_camera a view
  // from slightly behind and above T_world_camera when one is given.
  VirtualCamera camera(const std::optional<Eigen::Isometry3d>& T_world_camera = std::nullopt) const;

  // Renders `models` with the current colour mode, draws `overlay` plus the status line (and the
  // help when H is on), presents it and returns the picture (for screenshots).
  Image frame(gpu::Stream& stream, const ViewRenderer& renderer, std::span<const ModelView> models, Overlay overlay,
              const std::string& status_line);
  // Copies `image` into the next swapchain image (top-left aligned, clipped) and presents it.
  void present(const Image& image);

  int presented_frames() const { return presented_; }
  GLFWwindow* window() const { return window_; }

 private:
  struct Swapchain;
  void create_swapchain();
  // present()'s steps.
  std::optional<uint32_t> acquire_image();
  void fill_staging(const Image& image);
  void record_copy(vk::Image target);
  bool submit_and_present(uint32_t index);
  gpu::Context& ctx_;
  ViewerOptions options_;
  ViewerState state_;
  GLFWwindow* window_ = nullptr;
  vk::raii::SurfaceKHR surface_{nullptr};
  std::unique_ptr<Swapchain> swapchain_;
  vk::raii::CommandPool pool_{nullptr};
  vk::raii::CommandBuffer cmd_{nullptr};
  vk::raii::Fence fence_{nullptr};
  vk::raii::Semaphore acquired_{nullptr};
  gpu::BufferPtr staging_;
  int presented_ = 0;
  double last_x_ = 0, last_y_ = 0;
};

}  // namespace cofusion::renderer
