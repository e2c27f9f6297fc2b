#include "io/tum_writer.h"

#include <cstdio>

#include "common/error.h"
#include "io/atomic_file.h"
#include "io/image_io.h"
#include "io/intrinsics_option.h"

namespace cofusion {
namespace fs = std::filesystem;

TumFolderWriter::TumFolderWriter(fs::path dir, const Intrinsics& intrinsics, TumWriteOptions options)
    : dir_(std::move(dir)), intrinsics_(intrinsics), options_(options) {
  require_plausible(intrinsics_, "TUM output " + dir_.string());
  if (!(options_.depth_units_per_metre > 0)) throw Error("TUM output " + dir_.string() + ": depth scale must be positive");
  ensure_writable_directory(dir_ / "rgb");
  ensure_writable_directory(dir_ / "depth");
  const std::string header = "# file: written by cofusion convert\n# timestamp filename\n";
  rgb_list_ = "# color images\n" + header;
  depth_list_ = "# depth maps\n" + header;
}

void TumFolderWriter::write(const Frame& frame) {
  const std::string where = "TUM output " + dir_.string() + " frame " + std::to_string(frames_);
  if (frames_ > 0 && !(frame.timestamp_s > last_timestamp_s_))
    throw Error(where + ": timestamp " + std::to_string(frame.timestamp_s) + " s does not increase (previous " +
                std::to_string(last_timestamp_s_) + " s)");
  if (frame.rgb.type() != CV_8UC3) throw Error(where + ": colour is not CV_8UC3");
  if (frame.depth_m.type() != CV_32FC1) throw Error(where + ": depth is not CV_32FC1 metres");
  require_image_size(frame.rgb, intrinsics_.width, intrinsics_.height, where + " colour");
  require_image_size(frame.depth_m, intrinsics_.width, intrinsics_.height, where + " depth");
  const bool has_mask = !frame.mask.empty();
  if (frames_ == 0) {
    masks_ = has_mask;
    if (masks_) ensure_writable_directory(dir_ / "masks");
  } else if (has_mask != masks_) {
    throw Error(where + (has_mask ? ": has a mask but earlier frames had none" : ": has no mask but earlier frames had"));
  }
  if (has_mask) {
    if (frame.mask.type() != CV_16UC1) throw Error(where + ": mask is not CV_16UC1");
    require_image_size(frame.mask, intrinsics_.width, intrinsics_.height, where + " mask");
    keep_mask_classes(frame, where);
  }

  char stamp[64];
  std::snprintf(stamp, sizeof stamp, "%.6f", frame.timestamp_s);
  const std::string name = std::string(stamp) + ".png";
  write_rgb_image(dir_ / "rgb" / name, frame.rgb);
  write_u16_png(dir_ / "depth" / name, depth_to_u16(frame.depth_m, options_.depth_units_per_metre));
  if (has_mask) write_u16_png(dir_ / "masks" / name, frame.mask);

  rgb_list_ += std::string(stamp) + " rgb/" + name + "\n";
  depth_list_ += std::string(stamp) + " depth/" + name + "\n";
  associations_ += std::string(stamp) + " rgb/" + name + " " + stamp + " depth/" + name + "\n";
  if (frame.T_world_camera_gt) groundtruth_.push_back({frame.timestamp_s, *frame.T_world_camera_gt});
  last_timestamp_s_ = frame.timestamp_s;
  ++frames_;
}

void TumFolderWriter::keep_mask_classes(const Frame& frame, const std::string& where) {
  if (!frame.mask_classes) return;
  if (!mask_classes_) {
    mask_classes_ = frame.mask_classes;
  } else if (frame.mask_classes != mask_classes_ && frame.mask_classes->name_by_id != mask_classes_->name_by_id) {
    throw Error(where + ": its mask class table (" + frame.mask_classes->origin + ") differs from earlier frames' (" +
                mask_classes_->origin + ")");
  }
}

void TumFolderWriter::finish() {
  if (frames_ == 0) throw Error("TUM output " + dir_.string() + ": no frames were written");
  if (mask_classes_) write_instance_classes(dir_ / "masks" / kInstanceClassesFile, *mask_classes_);
  write_text_atomically(dir_ / "rgb.txt", rgb_list_);
  write_text_atomically(dir_ / "depth.txt", depth_list_);
  write_text_atomically(dir_ / "associations.txt", associations_);
  if (!groundtruth_.empty()) write_tum_trajectory(dir_ / "groundtruth.txt", groundtruth_);
  if (options_.write_calibration) {
    char line[256];
    std::snprintf(line, sizeof line, "%.6f %.6f %.6f %.6f %d %d\n", intrinsics_.fx, intrinsics_.fy, intrinsics_.cx,
                  intrinsics_.cy, intrinsics_.width, intrinsics_.height);
    write_text_atomically(dir_ / "calibration.txt", std::string("# fx fy cx cy width height (pixels)\n") + line);
  }
}

int write_tum_folder(FrameSource& source, const fs::path& dir, const TumWriteOptions& options) {
  TumFolderWriter writer(dir, source.intrinsics(), options);
  while (auto frame = source.next()) writer.write(*frame);
  writer.finish();
  return writer.frames_written();
}

}  // namespace cofusion
