#include "io/tum_source.h"

#include <algorithm>
#include <cctype>
#include <cmath>
#include <fstream>
#include <opencv2/imgcodecs.hpp>
#include <sstream>

#include "common/error.h"
#include "io/image_io.h"
#include "io/trajectory_lookup.h"

namespace cofusion {
namespace fs = std::filesystem;

namespace {

// Non-comment lines split into whitespace-separated tokens, with their line numbers.
template <class F>
void for_each_record(const fs::path& path, F&& on_record) {
  std::ifstream in(path);
  if (!in) throw Error("cannot open " + path.string());
  std::string line;
  int line_no = 0;
  while (std::getline(in, line)) {
    ++line_no;
    for (char& c : line)
      if (c == ',' || c == '\t' || c == '\r') c = ' ';
    const auto first = line.find_first_not_of(' ');
    if (first == std::string::npos || line[first] == '#') continue;
    std::istringstream ss(line);
    std::vector<std::string> tokens;
    for (std::string t; ss >> t;) tokens.push_back(t);
    on_record(tokens, line_no);
  }
}

double parse_timestamp(const std::string& token, const fs::path& path, int line_no) {
  std::istringstream ss(token);
  double t = 0;
  ss >> t;
  if (!ss || !ss.eof() || !std::isfinite(t))
    throw Error(path.string() + ":" + std::to_string(line_no) + ": '" + token + "' is not a timestamp");
  return t;
}

bool starts_with_folder(const std::string& file, const char* folder) {
  return file.rfind(folder, 0) == 0;
}

// masks/<name of the colour image>, with the extension .png when the colour image is not a PNG
// (rgb/x.jpg -> masks/x.png): masks must be lossless.
fs::path mask_path_for(const fs::path& folder, const std::string& rgb_file) {
  fs::path name = fs::path(rgb_file).filename();
  std::string ext = name.extension().string();
  for (char& c : ext) c = static_cast<char>(std::tolower(static_cast<unsigned char>(c)));
  if (ext != ".png") name.replace_extension(".png");
  return folder / "masks" / name;
}

}  // namespace

std::vector<TimedFile> read_tum_file_list(const fs::path& path) {
  std::vector<TimedFile> out;
  for_each_record(path, [&](const std::vector<std::string>& tokens, int line_no) {
    if (tokens.size() < 2)
      throw Error(path.string() + ":" + std::to_string(line_no) + ": expected 'timestamp file'");
    out.push_back({parse_timestamp(tokens[0], path, line_no), tokens[1]});
  });
  return out;
}

std::vector<TumAssociation> read_tum_associations(const fs::path& path) {
  std::vector<TumAssociation> out;
  for_each_record(path, [&](const std::vector<std::string>& tokens, int line_no) {
    if (tokens.size() < 4)
      throw Error(path.string() + ":" + std::to_string(line_no) + ": expected 't_rgb rgb/file t_depth depth/file'");
    TumAssociation a{{parse_timestamp(tokens[0], path, line_no), tokens[1]},
                     {parse_timestamp(tokens[2], path, line_no), tokens[3]}};
    if (starts_with_folder(a.rgb.file, "depth") && starts_with_folder(a.depth.file, "rgb")) std::swap(a.rgb, a.depth);
    out.push_back(a);
  });
  return out;
}

std::vector<TumAssociation> associate_by_time(const std::vector<TimedFile>& rgb, const std::vector<TimedFile>& depth,
                                              double max_dt_s) {
  // Depth indices sorted by time, so each rgb only looks at depth within +-max_dt_s.
  std::vector<std::size_t> depth_order(depth.size());
  for (std::size_t i = 0; i < depth.size(); ++i) depth_order[i] = i;
  std::sort(depth_order.begin(), depth_order.end(),
            [&](std::size_t a, std::size_t b) { return depth[a].timestamp_s < depth[b].timestamp_s; });
  struct Candidate {
    double dt;
    std::size_t rgb, depth;
  };
  std::vector<Candidate> candidates;
  for (std::size_t r = 0; r < rgb.size(); ++r) {
    const double t = rgb[r].timestamp_s;
    auto it = std::lower_bound(depth_order.begin(), depth_order.end(), t - max_dt_s,
                               [&](std::size_t d, double time) { return depth[d].timestamp_s < time; });
    for (; it != depth_order.end() && depth[*it].timestamp_s <= t + max_dt_s; ++it) {
      const double dt = std::abs(depth[*it].timestamp_s - t);
      if (dt < max_dt_s) candidates.push_back({dt, r, *it});
    }
  }
  std::stable_sort(candidates.begin(), candidates.end(),
                   [](const Candidate& a, const Candidate& b) { return a.dt < b.dt; });
  std::vector<bool> rgb_used(rgb.size(), false), depth_used(depth.size(), false);
  std::vector<TumAssociation> out;
  for (const auto& c : candidates) {
    if (rgb_used[c.rgb] || depth_used[c.depth]) continue;
    rgb_used[c.rgb] = depth_used[c.depth] = true;
    out.push_back({rgb[c.rgb], depth[c.depth]});
  }
  std::sort(out.begin(), out.end(),
            [](const TumAssociation& a, const TumAssociation& b) { return a.rgb.timestamp_s < b.rgb.timestamp_s; });
  return out;
}

TumSource::TumSource(fs::path folder, TumSourceOptions options) : folder_(std::move(folder)), options_(std::move(options)) {
  std::error_code ec;
  if (!fs::is_directory(folder_, ec)) throw Error("TUM folder " + folder_.string() + " does not exist or is not a folder");

  const fs::path associations = folder_ / "associations.txt";
  if (fs::is_regular_file(associations, ec)) {
    frames_ = read_tum_associations(associations);
    pairing_ = "associations.txt";
  } else {
    for (const char* name : {"rgb.txt", "depth.txt"})
      if (!fs::is_regular_file(folder_ / name, ec))
        throw Error("TUM folder " + folder_.string() + " has neither associations.txt nor " + name);
    frames_ = associate_by_time(read_tum_file_list(folder_ / "rgb.txt"), read_tum_file_list(folder_ / "depth.txt"),
                                options_.max_association_dt_s);
    pairing_ = "rgb/depth matched by time";
  }
  if (frames_.empty()) throw Error("TUM folder " + folder_.string() + " has no rgb/depth pairs (" + pairing_ + ")");

  has_masks_ = fs::is_directory(folder_ / "masks", ec);
  // A missing image is one bad frame (next() says which); none at all is the wrong folder.
  const auto pair_exists = [&](const TumAssociation& f) {
    return fs::is_regular_file(folder_ / f.rgb.file, ec) && fs::is_regular_file(folder_ / f.depth.file, ec);
  };
  if (std::none_of(frames_.begin(), frames_.end(), pair_exists))
    throw Error("TUM folder " + folder_.string() + ": not one of its " + std::to_string(frames_.size()) +
                " rgb/depth pairs exists (first: " + (folder_ / frames_.front().rgb.file).string() + ")");
  const fs::path classes = folder_ / "masks" / kInstanceClassesFile;
  if (has_masks_ && fs::is_regular_file(classes, ec))
    mask_classes_ = std::make_shared<const InstanceClasses>(read_instance_classes(classes));

  if (fs::is_regular_file(folder_ / "groundtruth.txt", ec)) {
    groundtruth_ = read_tum_trajectory(folder_ / "groundtruth.txt");
    std::stable_sort(groundtruth_.begin(), groundtruth_.end(),
                     [](const TimedPose& a, const TimedPose& b) { return a.timestamp_s < b.timestamp_s; });
  }

  if (!options_.intrinsics.empty()) {
    intrinsics_ = parse_intrinsics_option(options_.intrinsics);
  } else if (fs::is_regular_file(folder_ / "calibration.txt", ec)) {
    intrinsics_ = read_calibration_file(folder_ / "calibration.txt");
  } else if (const auto preset = guess_tum_preset(folder_)) {
    intrinsics_.intrinsics = *intrinsics_preset(*preset);
    intrinsics_.size_known = true;
    intrinsics_.origin = *preset + " preset (guessed from the path)";
    intrinsics_.tum_preset = *preset;
  } else {
    intrinsics_.intrinsics = *intrinsics_preset("primesense");
    intrinsics_.size_known = true;
    intrinsics_.origin = "primesense default (no --intrinsics, calibration.txt or fr1/fr2/fr3 in the path)";
  }
  if (!intrinsics_.size_known) {
    // Width and height come from the first colour image so intrinsics() is right before next().
    const cv::Mat first = read_rgb_image(folder_ / frames_.front().rgb.file);
    intrinsics_.intrinsics.width = first.cols;
    intrinsics_.intrinsics.height = first.rows;
    intrinsics_.size_known = true;
  }
  require_plausible(intrinsics_.intrinsics, "TUM folder " + folder_.string() + " (" + intrinsics_.origin + ")");

  if (options_.depth_correction) {
    depth_correction_ = *options_.depth_correction;
    require_plausible_depth_correction(depth_correction_, "TUM folder " + folder_.string());
    depth_correction_origin_ = "--depth-correction";
  } else if (!intrinsics_.tum_preset.empty()) {
    depth_correction_ = tum_depth_correction(intrinsics_.tum_preset).value_or(1.0);
    depth_correction_origin_ = intrinsics_.tum_preset + " depth correction";
  }
  if (!intrinsics_.tum_preset.empty()) colour_readout_s_ = tum_colour_readout_s(intrinsics_.tum_preset);
}

std::optional<Frame> TumSource::next() {
  if (next_ >= frames_.size()) return std::nullopt;
  const std::size_t i = next_++;  // past this frame even when it is bad
  return read_or_bad_frame(static_cast<int>(i), [&] { return read_frame(i); });
}

Frame TumSource::read_frame(std::size_t i) const {
  const TumAssociation& a = frames_[i];
  const Intrinsics& k = intrinsics_.intrinsics;
  Frame frame;
  frame.index = static_cast<int>(i);
  frame.timestamp_s = a.rgb.timestamp_s;
  frame.intrinsics = k;
  frame.colour_readout_s = colour_readout_s_;

  const fs::path rgb_path = folder_ / a.rgb.file;
  frame.rgb = read_rgb_image(rgb_path);
  require_image_size(frame.rgb, k.width, k.height, "colour image " + rgb_path.string() + " (size of the intrinsics: " + intrinsics_.origin + ")");
  const fs::path depth_path = folder_ / a.depth.file;
  frame.depth_m = read_depth_image(depth_path, options_.depth_units_per_metre * depth_correction_);
  require_image_size(frame.depth_m, k.width, k.height, "depth image " + depth_path.string() + " (size of the colour image)");
  if (has_masks_) {
    const fs::path mask_path = mask_path_for(folder_, a.rgb.file);
    frame.mask = read_mask_image(mask_path);
    require_image_size(frame.mask, k.width, k.height, "mask image " + mask_path.string() + " (size of the colour image)");
    if (mask_classes_) require_mask_ids_classified(frame.mask, *mask_classes_, mask_path);
    frame.mask_classes = mask_classes_;
  }
  frame.T_world_camera_gt = pose_at(groundtruth_, frame.timestamp_s, options_.max_groundtruth_dt_s);
  return frame;
}

std::string TumSource::describe() const {
  std::string s = "tum:" + folder_.string() + " (" + std::to_string(frames_.size()) + " frames, " + pairing_ + ", " +
                  intrinsics_.origin + ": " + intrinsics_.intrinsics.to_string();
  if (depth_correction_ != 1.0) s += ", " + depth_correction_label(depth_correction_, depth_correction_origin_);
  if (colour_readout_s_ != 0.0)
    s += ", colour rolling shutter " + std::to_string(int(std::lround(colour_readout_s_ * 1000))) + " ms (" +
         intrinsics_.tum_preset + ")";
  if (!groundtruth_.empty()) s += ", ground truth";
  if (has_masks_) s += mask_classes_ ? ", masks with classes" : ", masks";
  return s + ")";
}

}  // namespace cofusion
