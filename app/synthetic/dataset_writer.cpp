#include "synthetic/dataset_writer.h"

#include <tbb/parallel_pipeline.h>
#include <unistd.h>

#include <memory>
#include <random>
#include <sstream>

#include "common/error.h"
#include "io/atomic_file.h"
#include "io/trajectory.h"
#include "io/tum_writer.h"

namespace cofusion::synthetic {
namespace fs = std::filesystem;

namespace {

const char* shape_name(Shape s) {
  switch (s) {
    case Shape::kBox: return "box";
    case Shape::kSphere: return "sphere";
    case Shape::kCylinder: return "cylinder";
  }
  return "?";
}

void write_trajectory_file(const fs::path& path, const Trajectory& trajectory, const std::string& what) {
  std::string text = "# " + what + "\n# timestamp tx ty tz qx qy qz qw\n";
  for (const auto& p : trajectory) text += format_tum_line(p) + "\n";
  write_text_atomically(path, text);
}

bool non_empty_directory(const fs::path& p) {
  std::error_code ec;
  return fs::is_directory(p, ec) && !fs::is_empty(p, ec);
}

void write_contents(const SyntheticSequence& seq, const fs::path& dir, const DatasetOptions& options) {
  const int n = seq.size();
  if (n == 0) throw Error("the sequence has no frames");
  TumWriteOptions tum;
  tum.depth_units_per_metre = kTumDepthUnitsPerMetre;
  TumFolderWriter writer(dir, seq.intrinsics(), tum);
  ensure_writable_directory(dir / "geometry");

  // Frames render in parallel (a few in flight, each also parallel inside); the TUM writer takes
  // them one at a time in order.
  int next = 0;
  tbb::parallel_pipeline(
      4, tbb::make_filter<void, int>(tbb::filter_mode::serial_in_order,
                                     [&](tbb::flow_control& fc) {
                                       if (next >= n) {
                                         fc.stop();
                                         return 0;
                                       }
                                       return next++;
                                     }) &
             tbb::make_filter<int, std::shared_ptr<Frame>>(
                 tbb::filter_mode::parallel, [&](int i) { return std::make_shared<Frame>(seq.frame(i)); }) &
             tbb::make_filter<std::shared_ptr<Frame>, void>(tbb::filter_mode::serial_in_order,
                                                            [&](const std::shared_ptr<Frame>& frame) {
                                                              writer.write(*frame);
                                                              if (options.progress)
                                                                options.progress(frame->index + 1, n);
                                                            }));
  writer.finish();

  std::ostringstream objects;
  objects << "# id name shape first_frame last_frame (instance ids in masks/*.png)\n";
  for (const ObjectInfo& o : seq.objects()) {
    objects << o.id << " " << o.name << " " << (o.kind == ObjectKind::kPerson ? "person" : shape_name(o.shape)) << " "
            << o.first_frame << " " << o.last_frame
            << "\n";
    const std::string what = o.kind == ObjectKind::kPerson
                                 ? "ground truth pose T_world_pelvis of person " + std::to_string(o.id) + " (" + o.name +
                                       "; the pelvis only: the body is not rigid)"
                                 : "ground truth pose T_world_object of object " + std::to_string(o.id) + " (" + o.name + ")";
    write_trajectory_file(dir / ("groundtruth-" + std::to_string(o.id) + ".txt"), seq.object_trajectory(o.id), what);
    seq.write_glb(o.id, dir / "geometry" / ("object-" + std::to_string(o.id) + ".glb"));
  }
  write_text_atomically(dir / "objects.txt", objects.str());
  seq.write_glb(0, dir / "geometry" / "background.glb");
  write_text_atomically(dir / "scene.json", seq.scene().json_text);
}

}  // namespace

void write_tum_dataset(const SyntheticSequence& seq, const fs::path& out_dir, const DatasetOptions& options) {
  const fs::path target = fs::absolute(out_dir).lexically_normal();
  const fs::path parent = target.parent_path();
  if (target.filename().empty()) throw Error("output folder " + out_dir.string() + " has no name");
  if (non_empty_directory(target) && !options.overwrite)
    throw Error("output folder " + target.string() + " exists and is not empty (use --overwrite to replace it)");
  std::error_code ec;
  if (fs::exists(target, ec) && !fs::is_directory(target, ec))
    throw Error("output path " + target.string() + " exists and is not a folder");
  ensure_writable_directory(parent);

  const std::string unique = std::to_string(::getpid()) + "-" + std::to_string(std::random_device{}());
  const fs::path tmp = parent / (target.filename().string() + ".tmp-" + unique);
  try {
    fs::create_directories(tmp);
    write_contents(seq, tmp, options);
    if (fs::exists(target)) {
      // Empty folder: replace it. Non-empty (overwrite): move it aside first, so the target name
      // always holds a complete dataset.
      const fs::path old = parent / (target.filename().string() + ".old-" + unique);
      fs::rename(target, old);
      fs::rename(tmp, target);
      fs::remove_all(old, ec);
    } else {
      fs::rename(tmp, target);
    }
  } catch (const std::exception& e) {
    fs::remove_all(tmp, ec);
    throw Error("cannot write dataset " + target.string() + ": " + e.what());
  }
}

}  // namespace cofusion::synthetic
