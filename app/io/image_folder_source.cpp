#include "io/image_folder_source.h"

#include <algorithm>
#include <cctype>
#include <cmath>
#include <fstream>
#include <sstream>

#include "common/error.h"
#include "io/image_io.h"

namespace cofusion {
namespace fs = std::filesystem;

namespace {

// "frame2" < "frame10": runs of digits compare by value, everything else byte-wise.
bool natural_less(const std::string& a, const std::string& b) {
  std::size_t i = 0, j = 0;
  while (i < a.size() && j < b.size()) {
    const bool da = std::isdigit(static_cast<unsigned char>(a[i])), db = std::isdigit(static_cast<unsigned char>(b[j]));
    if (da && db) {
      std::size_t ie = i, je = j;
      while (ie < a.size() && std::isdigit(static_cast<unsigned char>(a[ie]))) ++ie;
      while (je < b.size() && std::isdigit(static_cast<unsigned char>(b[je]))) ++je;
      // Compare by value: strip leading zeros, then longer is larger, then lexicographic.
      std::size_t is = i, js = j;
      while (is + 1 < ie && a[is] == '0') ++is;
      while (js + 1 < je && b[js] == '0') ++js;
      if (ie - is != je - js) return ie - is < je - js;
      if (const int c = a.compare(is, ie - is, b, js, je - js); c != 0) return c < 0;
      if (ie - i != je - j) return ie - i < je - j;  // same value: less zero padding first
      i = ie;
      j = je;
    } else {
      if (a[i] != b[j]) return static_cast<unsigned char>(a[i]) < static_cast<unsigned char>(b[j]);
      ++i;
      ++j;
    }
  }
  return a.size() - i < b.size() - j;
}

std::string lower(std::string s) {
  std::transform(s.begin(), s.end(), s.begin(), [](unsigned char c) { return std::tolower(c); });
  return s;
}

}  // namespace

std::vector<fs::path> list_images_sorted(const fs::path& dir) {
  static const char* const kExtensions[] = {".png", ".jpg", ".jpeg", ".exr", ".tif", ".tiff", ".ppm", ".pgm", ".bmp"};
  std::vector<fs::path> files;
  std::error_code ec;
  for (const auto& entry : fs::directory_iterator(dir, ec)) {
    if (!entry.is_regular_file()) continue;
    const std::string ext = lower(entry.path().extension().string());
    if (std::find(std::begin(kExtensions), std::end(kExtensions), ext) != std::end(kExtensions))
      files.push_back(entry.path());
  }
  if (ec) throw Error("cannot list image folder " + dir.string() + ": " + ec.message());
  std::sort(files.begin(), files.end(),
            [](const fs::path& a, const fs::path& b) { return natural_less(a.filename().string(), b.filename().string()); });
  return files;
}

ImageFolderSource::ImageFolderSource(fs::path folder, ImageFolderSourceOptions options)
    : folder_(std::move(folder)), options_(std::move(options)) {
  std::error_code ec;
  if (!fs::is_directory(folder_, ec)) throw Error("image folder " + folder_.string() + " does not exist or is not a folder");
  if (!(options_.frame_rate_hz > 0)) throw Error("image folder " + folder_.string() + ": frame rate must be positive");

  fs::path colour_dir;
  for (const char* name : {"colour", "color", "rgb"})
    if (fs::is_directory(folder_ / name, ec)) {
      colour_dir = folder_ / name;
      break;
    }
  if (colour_dir.empty()) throw Error("image folder " + folder_.string() + " has no colour/ (or color/, rgb/) subfolder");
  if (!fs::is_directory(folder_ / "depth", ec)) throw Error("image folder " + folder_.string() + " has no depth/ subfolder");
  rgb_files_ = list_images_sorted(colour_dir);
  depth_files_ = list_images_sorted(folder_ / "depth");
  if (rgb_files_.empty()) throw Error("image folder " + colour_dir.string() + " holds no images");
  if (depth_files_.size() != rgb_files_.size())
    throw Error("image folder " + folder_.string() + ": " + std::to_string(rgb_files_.size()) + " colour images in " +
                colour_dir.string() + " but " + std::to_string(depth_files_.size()) + " depth images in " +
                (folder_ / "depth").string());
  if (fs::is_directory(folder_ / "masks", ec)) {
    mask_files_ = list_images_sorted(folder_ / "masks");
    if (mask_files_.size() != rgb_files_.size())
      throw Error("image folder " + folder_.string() + ": " + std::to_string(rgb_files_.size()) + " colour images but " +
                  std::to_string(mask_files_.size()) + " masks in " + (folder_ / "masks").string());
    const fs::path classes = folder_ / "masks" / kInstanceClassesFile;
    if (fs::is_regular_file(classes, ec))
      mask_classes_ = std::make_shared<const InstanceClasses>(read_instance_classes(classes));
  }

  const fs::path timestamps = folder_ / "timestamps.txt";
  if (fs::is_regular_file(timestamps, ec)) {
    std::ifstream in(timestamps);
    if (!in) throw Error("cannot open " + timestamps.string());
    std::string line;
    int line_no = 0;
    while (std::getline(in, line)) {
      ++line_no;
      std::istringstream ss(line);
      std::string token;
      if (!(ss >> token) || token[0] == '#') continue;
      std::istringstream num(token);
      double t = 0;
      if (!(num >> t) || !num.eof() || !std::isfinite(t))
        throw Error(timestamps.string() + ":" + std::to_string(line_no) + ": '" + token + "' is not a timestamp");
      timestamps_s_.push_back(t);
    }
    if (timestamps_s_.size() != rgb_files_.size())
      throw Error(timestamps.string() + ": " + std::to_string(timestamps_s_.size()) + " timestamps for " +
                  std::to_string(rgb_files_.size()) + " frames");
  } else {
    for (std::size_t i = 0; i < rgb_files_.size(); ++i)
      timestamps_s_.push_back(static_cast<double>(i) / options_.frame_rate_hz);
  }

  if (!options_.intrinsics.empty()) {
    intrinsics_ = parse_intrinsics_option(options_.intrinsics);
  } else if (fs::is_regular_file(folder_ / "calibration.txt", ec)) {
    intrinsics_ = read_calibration_file(folder_ / "calibration.txt");
  } else {
    intrinsics_.intrinsics = *intrinsics_preset("primesense");
    intrinsics_.origin = "primesense default (no --intrinsics or calibration.txt)";
  }
  if (!intrinsics_.size_known) {
    const cv::Mat first = read_rgb_image(rgb_files_.front());
    intrinsics_.intrinsics.width = first.cols;
    intrinsics_.intrinsics.height = first.rows;
    intrinsics_.size_known = true;
  }
  require_plausible(intrinsics_.intrinsics, "image folder " + folder_.string() + " (" + intrinsics_.origin + ")");
}

std::optional<Frame> ImageFolderSource::next() {
  if (next_ >= rgb_files_.size()) return std::nullopt;
  const std::size_t i = next_++;  // past this frame even when it is bad
  return read_or_bad_frame(static_cast<int>(i), [&] { return read_frame(i); });
}

Frame ImageFolderSource::read_frame(std::size_t i) const {
  const Intrinsics& k = intrinsics_.intrinsics;
  Frame frame;
  frame.index = static_cast<int>(i);
  frame.timestamp_s = timestamps_s_[i];
  frame.intrinsics = k;
  frame.rgb = read_rgb_image(rgb_files_[i]);
  require_image_size(frame.rgb, k.width, k.height, "colour image " + rgb_files_[i].string());
  frame.depth_m = read_depth_image(depth_files_[i], options_.depth_units_per_metre);
  require_image_size(frame.depth_m, k.width, k.height, "depth image " + depth_files_[i].string());
  if (!mask_files_.empty()) {
    frame.mask = read_mask_image(mask_files_[i]);
    require_image_size(frame.mask, k.width, k.height, "mask image " + mask_files_[i].string());
    if (mask_classes_) require_mask_ids_classified(frame.mask, *mask_classes_, mask_files_[i]);
    frame.mask_classes = mask_classes_;
  }
  return frame;
}

std::string ImageFolderSource::describe() const {
  const char* masks = mask_files_.empty() ? "" : mask_classes_ ? ", masks with classes" : ", masks";
  return "images:" + folder_.string() + " (" + std::to_string(rgb_files_.size()) + " frames, " + intrinsics_.origin +
         ": " + intrinsics_.intrinsics.to_string() + masks + ")";
}

}  // namespace cofusion
