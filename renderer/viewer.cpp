#include "renderer/viewer.h"

#define GLFW_INCLUDE_VULKAN
#include <GLFW/glfw3.h>

#include <algorithm>
#include <cmath>
#include <cstring>
#include <limits>

#include "common/error.h"

namespace cofusion::renderer {

// ---- orbit camera and key handling (no window needed) ---------------------------------------

Eigen::Isometry3d OrbitCamera::T_world_view() const {
  const Eigen::Vector3d back(-std::sin(yaw_rad) * std::cos(pitch_rad), -std::sin(pitch_rad),
                             -std::cos(yaw_rad) * std::cos(pitch_rad));
  return look_at(target_world + distance_m * back, target_world, Eigen::Vector3d(0, -1, 0));
}

void OrbitCamera::orbit(double dx_px, double dy_px) {
  constexpr double rad_per_px = 0.005;
  yaw_rad -= dx_px * rad_per_px;
  // Stay short of straight up/down, where look_at's up vector is undefined.
  pitch_rad = std::clamp(pitch_rad + dy_px * rad_per_px, -1.5, 1.5);
}

void OrbitCamera::pan(double dx_px, double dy_px) {
  const double metres_per_px = 0.0015 * distance_m;
  const Eigen::Matrix3d R = T_world_view().linear();
  target_world -= R * Eigen::Vector3d(dx_px, dy_px, 0) * metres_per_px;
}

void OrbitCamera::zoom(double wheel_steps) { distance_m = std::clamp(distance_m * std::pow(0.9, wheel_steps), 0.05, 100.0); }

bool ViewerState::on_key(int glfw_key) {
  switch (glfw_key) {
    case GLFW_KEY_1: colour_mode = ColourMode::Rgb; return true;
    case GLFW_KEY_2: colour_mode = ColourMode::ModelLabel; return true;
    case GLFW_KEY_3: colour_mode = ColourMode::Normal; return true;
    case GLFW_KEY_4: colour_mode = ColourMode::Confidence; return true;
    case GLFW_KEY_F: follow_camera = !follow_camera; return true;
    case GLFW_KEY_SPACE: paused = !paused; return true;
    case GLFW_KEY_N:
      paused = true;  // single stepping implies pausing after the step
      step_requested = true;
      return true;
    case GLFW_KEY_H: show_help = !show_help; return true;
    case GLFW_KEY_Q:
    case GLFW_KEY_ESCAPE: quit_requested = true; return true;
    default: return false;
  }
}

std::vector<std::string> ViewerState::help_lines() {
  return {"1-4   colour: rgb, label, normal, confidence",
          "F     follow camera",
          "SPACE pause      N  single step",
          "H     this help  Q/ESC quit",
          "mouse: left orbit, right pan, wheel zoom"};
}

// ---- the window -----------------------------------------------------------------------------

struct Viewer::Swapchain {
  vk::raii::SwapchainKHR handle{nullptr};
  std::vector<vk::Image> images;
  std::vector<vk::raii::Semaphore> rendered;  // per image: a present may still wait on it
  vk::Format format = vk::Format::eUndefined;
  vk::Extent2D extent;
  bool bgra = false;
};

namespace {
void init_glfw() {
  if (!glfwInit())
    throw Error("viewer: GLFW could not be initialised (no display? set DISPLAY or run under xvfb-run)");
  if (!glfwVulkanSupported()) throw Error("viewer: GLFW finds no Vulkan loader for windows");
}
}  // namespace

void Viewer::add_required_extensions(gpu::ContextOptions& options) {
  init_glfw();
  uint32_t count = 0;
  const char** names = glfwGetRequiredInstanceExtensions(&count);
  if (!names) throw Error("viewer: no Vulkan surface extensions for this window system");
  for (uint32_t i = 0; i < count; ++i)
    if (std::find(options.instance_extensions.begin(), options.instance_extensions.end(), names[i]) ==
        options.instance_extensions.end())
      options.instance_extensions.emplace_back(names[i]);
  const std::string swapchain = VK_KHR_SWAPCHAIN_EXTENSION_NAME;
  if (std::find(options.device_extensions.begin(), options.device_extensions.end(), swapchain) ==
      options.device_extensions.end())
    options.device_extensions.push_back(swapchain);
}

Viewer::Viewer(gpu::Context& ctx, const ViewerOptions& options) : ctx_(ctx), options_(options) {
  if (options.width <= 0 || options.height <= 0)
    throw Error("viewer: window size " + std::to_string(options.width) + "x" + std::to_string(options.height) +
                " is not positive");
  init_glfw();
  glfwWindowHint(GLFW_CLIENT_API, GLFW_NO_API);
  window_ = glfwCreateWindow(options.width, options.height, options.title.c_str(), nullptr, nullptr);
  if (!window_) throw Error("viewer: GLFW could not create a " + std::to_string(options.width) + "x" +
                            std::to_string(options.height) + " window");
  try {
    VkSurfaceKHR raw = VK_NULL_HANDLE;
    gpu::vk_check(glfwCreateWindowSurface(*ctx.instance(), window_, nullptr, &raw), "glfwCreateWindowSurface");
    surface_ = vk::raii::SurfaceKHR(ctx.instance(), raw);
    if (!ctx.physical_device().getSurfaceSupportKHR(ctx.compute_queue_family(), *surface_))
      throw Error("viewer: the device's compute queue family " + std::to_string(ctx.compute_queue_family()) +
                  " cannot present to this window");
    pool_ = vk::raii::CommandPool(ctx.device(), {.flags = vk::CommandPoolCreateFlagBits::eResetCommandBuffer,
                                                 .queueFamilyIndex = ctx.compute_queue_family()});
    cmd_ = std::move(vk::raii::CommandBuffers(ctx.device(), {.commandPool = *pool_,
                                                             .level = vk::CommandBufferLevel::ePrimary,
                                                             .commandBufferCount = 1})
                         .front());
    fence_ = vk::raii::Fence(ctx.device(), {.flags = vk::FenceCreateFlagBits::eSignaled});
    acquired_ = vk::raii::Semaphore(ctx.device(), vk::SemaphoreCreateInfo{});
    create_swapchain();
  } catch (...) {
    swapchain_.reset();
    surface_.clear();
    glfwDestroyWindow(window_);
    throw;
  }

  glfwSetWindowUserPointer(window_, this);
  glfwSetKeyCallback(window_, [](GLFWwindow* w, int key, int, int action, int) {
    auto* self = static_cast<Viewer*>(glfwGetWindowUserPointer(w));
    if (action == GLFW_PRESS && self->state_.on_key(key) && self->state_.quit_requested)
      glfwSetWindowShouldClose(w, GLFW_TRUE);
  });
  glfwSetScrollCallback(window_, [](GLFWwindow* w, double, double dy) {
    static_cast<Viewer*>(glfwGetWindowUserPointer(w))->state_.orbit.zoom(dy);
  });
  glfwSetCursorPosCallback(window_, [](GLFWwindow* w, double x, double y) {
    auto* self = static_cast<Viewer*>(glfwGetWindowUserPointer(w));
    const double dx = x - self->last_x_, dy = y - self->last_y_;
    self->last_x_ = x;
    self->last_y_ = y;
    if (glfwGetMouseButton(w, GLFW_MOUSE_BUTTON_LEFT) == GLFW_PRESS)
      self->state_.orbit.orbit(dx, dy);
    else if (glfwGetMouseButton(w, GLFW_MOUSE_BUTTON_RIGHT) == GLFW_PRESS ||
             glfwGetMouseButton(w, GLFW_MOUSE_BUTTON_MIDDLE) == GLFW_PRESS)
      self->state_.orbit.pan(dx, dy);
  });
}

Viewer::~Viewer() {
  // Nothing may be destroyed while the last copy or present still uses it.
  (void)ctx_.device().waitForFences({*fence_}, VK_TRUE, std::numeric_limits<uint64_t>::max());
  {
    std::lock_guard lock(ctx_.queue_for_worker(0).mutex);
    ctx_.queue_for_worker(0).handle.waitIdle();
  }
  swapchain_.reset();
  surface_.clear();
  glfwDestroyWindow(window_);
  glfwTerminate();
}

void Viewer::create_swapchain() {
  const auto& pd = ctx_.physical_device();
  const auto caps = pd.getSurfaceCapabilitiesKHR(*surface_);
  int fb_w = 0, fb_h = 0;
  glfwGetFramebufferSize(window_, &fb_w, &fb_h);
  vk::Extent2D extent = caps.currentExtent;
  if (extent.width == std::numeric_limits<uint32_t>::max())
    extent = vk::Extent2D{std::clamp(static_cast<uint32_t>(fb_w), caps.minImageExtent.width, caps.maxImageExtent.width),
                          std::clamp(static_cast<uint32_t>(fb_h), caps.minImageExtent.height, caps.maxImageExtent.height)};
  auto old = std::move(swapchain_);
  swapchain_ = std::make_unique<Swapchain>();
  swapchain_->extent = extent;
  if (extent.width == 0 || extent.height == 0) return;  // minimised: present() skips frames
  if (!(caps.supportedUsageFlags & vk::ImageUsageFlagBits::eTransferDst))
    throw Error("viewer: the window's swapchain images cannot be copied to (no TRANSFER_DST usage)");
  const auto formats = pd.getSurfaceFormatsKHR(*surface_);
  vk::SurfaceFormatKHR chosen{};
  for (vk::Format f : {vk::Format::eB8G8R8A8Unorm, vk::Format::eR8G8B8A8Unorm, vk::Format::eB8G8R8A8Srgb,
                       vk::Format::eR8G8B8A8Srgb}) {
    const auto it = std::find_if(formats.begin(), formats.end(), [&](const vk::SurfaceFormatKHR& s) { return s.format == f; });
    if (it != formats.end()) {
      chosen = *it;
      break;
    }
  }
  if (chosen.format == vk::Format::eUndefined) throw Error("viewer: the window offers no 8-bit RGBA/BGRA format");
  swapchain_->format = chosen.format;
  swapchain_->bgra = chosen.format == vk::Format::eB8G8R8A8Unorm || chosen.format == vk::Format::eB8G8R8A8Srgb;
  uint32_t image_count = caps.minImageCount + 1;
  if (caps.maxImageCount > 0) image_count = std::min(image_count, caps.maxImageCount);
  vk::SwapchainCreateInfoKHR info{.surface = *surface_,
                                  .minImageCount = image_count,
                                  .imageFormat = chosen.format,
                                  .imageColorSpace = chosen.colorSpace,
                                  .imageExtent = extent,
                                  .imageArrayLayers = 1,
                                  .imageUsage = vk::ImageUsageFlagBits::eTransferDst,
                                  .imageSharingMode = vk::SharingMode::eExclusive,
                                  .preTransform = caps.currentTransform,
                                  .compositeAlpha = vk::CompositeAlphaFlagBitsKHR::eOpaque,
                                  .presentMode = vk::PresentModeKHR::eFifo,  // always available
                                  .clipped = VK_TRUE,
                                  .oldSwapchain = old && *old->handle ? *old->handle : vk::SwapchainKHR{}};
  swapchain_->handle = vk::raii::SwapchainKHR(ctx_.device(), info);
  swapchain_->images = swapchain_->handle.getImages();
  for (size_t i = 0; i < swapchain_->images.size(); ++i)
    swapchain_->rendered.emplace_back(ctx_.device(), vk::SemaphoreCreateInfo{});
  if (old) {
    // The old swapchain's presents must finish before its semaphores go.
    std::lock_guard lock(ctx_.queue_for_worker(0).mutex);
    ctx_.queue_for_worker(0).handle.waitIdle();
  }
}

bool Viewer::poll() {
  glfwPollEvents();
  if (glfwWindowShouldClose(window_)) state_.quit_requested = true;
  return !state_.quit_requested;
}

VirtualCamera Viewer::camera(const std::optional<Eigen::Isometry3d>& T_world_camera) const {
  int w = 0, h = 0;
  glfwGetFramebufferSize(window_, &w, &h);
  VirtualCamera cam;
  cam.intrinsics.width = std::max(w, 1);
  cam.intrinsics.height = std::max(h, 1);
  const double half_fov = 0.5 * options_.fov_y_deg * M_PI / 180.0;
  cam.intrinsics.fy = 0.5 * cam.intrinsics.height / std::tan(half_fov);
  cam.intrinsics.fx = cam.intrinsics.fy;
  cam.intrinsics.cx = (cam.intrinsics.width - 1) / 2.0;
  cam.intrinsics.cy = (cam.intrinsics.height - 1) / 2.0;
  if (state_.follow_camera && T_world_camera)
    cam.T_world_view = *T_world_camera * Eigen::Translation3d(0, -0.15, -0.5);  // behind and above (y is down)
  else
    cam.T_world_view = state_.orbit.T_world_view();
  return cam;
}

Image Viewer::frame(gpu::Stream& stream, const ViewRenderer& renderer, std::span<const ModelView> models,
                    Overlay overlay, const std::string& status_line) {
  const VirtualCamera cam = camera(overlay.T_world_camera);
  RenderParams params;
  params.colour_mode = state_.colour_mode;
  Image image = renderer.render(stream, models, cam, params);
  std::string status = status_line + "  [" + to_string(state_.colour_mode) + (state_.paused ? ", paused" : "") +
                       (state_.follow_camera ? ", follow" : "") + "]  H: help";
  overlay.text_lines.insert(overlay.text_lines.begin(), status);
  if (state_.show_help)
    for (auto& line : ViewerState::help_lines()) overlay.text_lines.push_back(line);
  // Large windows get doubled text so the 5x7 font stays readable.
  overlay.text_scale = std::max(overlay.text_scale, cam.intrinsics.width >= 1280 ? 2 : 1);
  draw_overlay(image, cam, overlay);
  present(image);
  return image;
}

void Viewer::present(const Image& image) {
  if (!swapchain_ || swapchain_->extent.width == 0 || !*swapchain_->handle) {
    create_swapchain();
    if (swapchain_->extent.width == 0) return;
  }
  const std::optional<uint32_t> index = acquire_image();
  if (!index) return;
  fill_staging(image);
  record_copy(swapchain_->images[*index]);
  if (!submit_and_present(*index)) create_swapchain();
  ++presented_;
}

// Waits for the previous frame and acquires the next swapchain image; none when the swapchain
// was out of date (it is recreated).
std::optional<uint32_t> Viewer::acquire_image() {
  const auto& device = ctx_.device();
  if (device.waitForFences({*fence_}, VK_TRUE, std::numeric_limits<uint64_t>::max()) != vk::Result::eSuccess)
    throw Error("viewer: waiting for the previous frame failed");
  uint32_t index = 0;
  try {
    const auto [result, i] = swapchain_->handle.acquireNextImage(std::numeric_limits<uint64_t>::max(), *acquired_);
    (void)result;  // suboptimal still presents; the next out-of-date recreates
    index = i;
  } catch (const vk::OutOfDateKHRError&) {
    create_swapchain();
    return std::nullopt;
  }
  device.resetFences({*fence_});
  return index;
}

// The image into the host-visible staging buffer at the swapchain's size and byte order (black
// outside the image).
void Viewer::fill_staging(const Image& image) {
  const vk::Extent2D extent = swapchain_->extent;
  const size_t bytes = static_cast<size_t>(extent.width) * extent.height * 4;
  if (!staging_ || staging_->size() != bytes)
    staging_ = gpu::Buffer::create(ctx_, bytes, "viewer staging", gpu::BufferUsage::Staging);
  auto* dst = static_cast<uint32_t*>(staging_->mapped());
  for (uint32_t y = 0; y < extent.height; ++y)
    for (uint32_t x = 0; x < extent.width; ++x) {
      uint32_t px = 0xFF000000u;
      if (static_cast<int>(x) < image.width && static_cast<int>(y) < image.height) px = image.at(static_cast<int>(x), static_cast<int>(y));
      if (swapchain_->bgra) px = (px & 0xFF00FF00u) | ((px & 0xFFu) << 16) | ((px >> 16) & 0xFFu);
      dst[static_cast<size_t>(y) * extent.width + x] = px;
    }
}

// Records the staging buffer's copy into `target`, with its layout transitions for the copy and
// for presenting.
void Viewer::record_copy(vk::Image target) {
  const vk::Extent2D extent = swapchain_->extent;
  const vk::ImageSubresourceRange range{vk::ImageAspectFlagBits::eColor, 0, 1, 0, 1};
  cmd_.reset();
  cmd_.begin({.flags = vk::CommandBufferUsageFlagBits::eOneTimeSubmit});
  vk::ImageMemoryBarrier2 to_copy{.srcStageMask = vk::PipelineStageFlagBits2::eAllTransfer,
                                  .srcAccessMask = vk::AccessFlagBits2::eNone,
                                  .dstStageMask = vk::PipelineStageFlagBits2::eAllTransfer,
                                  .dstAccessMask = vk::AccessFlagBits2::eTransferWrite,
                                  .oldLayout = vk::ImageLayout::eUndefined,
                                  .newLayout = vk::ImageLayout::eTransferDstOptimal,
                                  .image = target,
                                  .subresourceRange = range};
  cmd_.pipelineBarrier2({.imageMemoryBarrierCount = 1, .pImageMemoryBarriers = &to_copy});
  const vk::BufferImageCopy region{.bufferOffset = 0,
                                   .bufferRowLength = 0,
                                   .bufferImageHeight = 0,
                                   .imageSubresource = {vk::ImageAspectFlagBits::eColor, 0, 0, 1},
                                   .imageOffset = {0, 0, 0},
                                   .imageExtent = {extent.width, extent.height, 1}};
  cmd_.copyBufferToImage(staging_->handle(), target, vk::ImageLayout::eTransferDstOptimal, region);
  vk::ImageMemoryBarrier2 to_present{.srcStageMask = vk::PipelineStageFlagBits2::eAllTransfer,
                                     .srcAccessMask = vk::AccessFlagBits2::eTransferWrite,
                                     .dstStageMask = vk::PipelineStageFlagBits2::eNone,
                                     .dstAccessMask = vk::AccessFlagBits2::eNone,
                                     .oldLayout = vk::ImageLayout::eTransferDstOptimal,
                                     .newLayout = vk::ImageLayout::ePresentSrcKHR,
                                     .image = target,
                                     .subresourceRange = range};
  cmd_.pipelineBarrier2({.imageMemoryBarrierCount = 1, .pImageMemoryBarriers = &to_present});
  cmd_.end();
}

// Submits the recorded copy (after the acquisition, signalling the image's semaphore) and presents
// the image; false when the swapchain needs recreating (suboptimal or out of date).
bool Viewer::submit_and_present(uint32_t index) {
  const vk::SemaphoreSubmitInfo wait{.semaphore = *acquired_, .stageMask = vk::PipelineStageFlagBits2::eAllTransfer};
  const vk::SemaphoreSubmitInfo signal{.semaphore = *swapchain_->rendered[index],
                                       .stageMask = vk::PipelineStageFlagBits2::eAllTransfer};
  const vk::CommandBufferSubmitInfo cmd_info{.commandBuffer = *cmd_};
  const vk::Semaphore rendered = *swapchain_->rendered[index];
  const vk::SwapchainKHR swapchain = *swapchain_->handle;
  gpu::Queue& queue = ctx_.queue_for_worker(0);
  std::lock_guard lock(queue.mutex);
  const vk::raii::Queue raii_queue(ctx_.device(), queue.family, queue.index);
  raii_queue.submit2(vk::SubmitInfo2{.waitSemaphoreInfoCount = 1,
                                     .pWaitSemaphoreInfos = &wait,
                                     .commandBufferInfoCount = 1,
                                     .pCommandBufferInfos = &cmd_info,
                                     .signalSemaphoreInfoCount = 1,
                                     .pSignalSemaphoreInfos = &signal},
                     *fence_);
  try {
    const vk::Result r = raii_queue.presentKHR(
        {.waitSemaphoreCount = 1, .pWaitSemaphores = &rendered, .swapchainCount = 1, .pSwapchains = &swapchain,
         .pImageIndices = &index});
    return r != vk::Result::eSuboptimalKHR;
  } catch (const vk::OutOfDateKHRError&) {
    return false;
  }
}

}  // namespace cofusion::renderer
