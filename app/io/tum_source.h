#pragma once
// TUM RGB-D benchmark folders: rgb.txt/depth.txt (or associations.txt), 8-bit colour PNGs, 16-bit
// depth PNGs (5000 units per metre), optional groundtruth.txt, optional masks/ (8- or 16-bit
// instance ids named like the colour files, as the synthetic generator writes them; always PNG:
// rgb/x.jpg has masks/x.png) with an optional masks/classes.txt (io/instance_classes.h), and
// calibration.txt.
#include <filesystem>
#include <memory>
#include <optional>
#include <string>
#include <vector>

#include "io/frame.h"
#include "io/intrinsics_option.h"
#include "io/trajectory.h"

namespace cofusion {

struct TumSourceOptions {
  // --intrinsics ("fx,fy,cx,cy[,w,h]", preset or file). Empty: the folder's calibration.txt, else
  // the preset named by the path (freiburg1/2/3 or fr1/2/3), else primesense (and describe() says so).
  std::string intrinsics;
  double depth_units_per_metre = 5000.0;  // TUM depth PNG scale
  // --depth-correction: recorded depth / this = metric depth (0.5-2). Empty: the TUM camera's own
  // correction when the intrinsics are a TUM preset (fr1 1.035, fr2 1.031), else 1.
  std::optional<double> depth_correction;
  double max_association_dt_s = 0.02;     // rgb/depth pairing without associations.txt (associate.py)
  double max_groundtruth_dt_s = 0.02;     // ground truth is attached when samples are this close
};

// One line of rgb.txt / depth.txt: timestamp and file path relative to the folder.
struct TimedFile {
  double timestamp_s = 0;
  std::string file;
};
struct TumAssociation {
  TimedFile rgb;
  TimedFile depth;
};

// "timestamp file" lines ('#' comments); throws cofusion::Error naming file and line.
std::vector<TimedFile> read_tum_file_list(const std::filesystem::path& path);
// "t_rgb rgb/file t_depth depth/file" lines (a file with the depth columns first is recognised by
// the folder names and swapped).
std::vector<TumAssociation> read_tum_associations(const std::filesystem::path& path);
// Nearest-timestamp pairing as TUM's associate.py does it: candidate pairs closer than max_dt_s,
// taken greedily from the closest, each rgb and each depth used at most once; sorted by rgb time.
std::vector<TumAssociation> associate_by_time(const std::vector<TimedFile>& rgb, const std::vector<TimedFile>& depth,
                                              double max_dt_s);

class TumSource : public FrameSource {
 public:
  // Reads the file lists; images load in next(). Throws cofusion::Error naming the folder or file
  // on bad input, and when not one listed rgb/depth pair exists (the wrong folder). A single
  // missing, corrupt or wrongly sized image is a BadFrame from next().
  explicit TumSource(std::filesystem::path folder, TumSourceOptions options = {});

  std::optional<Frame> next() override;
  Intrinsics intrinsics() const override { return intrinsics_.intrinsics; }
  // The divisor applied to every depth reading (1 = none); see TumSourceOptions::depth_correction.
  double depth_correction() const { return depth_correction_; }
  // The colour camera's rolling-shutter readout every frame carries (Frame::colour_readout_s).
  double colour_readout_s() const { return colour_readout_s_; }
  std::optional<int> size() const override { return static_cast<int>(frames_.size()); }
  std::string describe() const override;

  bool has_groundtruth() const { return !groundtruth_.empty(); }

 private:
  Frame read_frame(std::size_t i) const;

  std::filesystem::path folder_;
  TumSourceOptions options_;
  IntrinsicsChoice intrinsics_;
  double depth_correction_ = 1.0;
  std::string depth_correction_origin_;
  double colour_readout_s_ = 0.0;  // tum_colour_readout_s of the preset, 0 without one
  std::vector<TumAssociation> frames_;
  Trajectory groundtruth_;  // sorted by time; empty without groundtruth.txt
  bool has_masks_ = false;
  std::shared_ptr<const InstanceClasses> mask_classes_;  // masks/classes.txt; null without one
  std::string pairing_;     // "associations.txt" or "rgb.txt/depth.txt matched by time"
  std::size_t next_ = 0;
};

}  // namespace cofusion
