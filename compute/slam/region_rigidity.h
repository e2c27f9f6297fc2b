#pragma once
// Does an outlier region move as one rigid body between the previous frame and this one? A region
// about to spawn a model is aligned to the previous frame's depth by point-to-plane ICP (its own
// rigid motion, from the camera's); a rigid object's points then all land on the surface they came
// from, up to noise, while a walking person's limbs, which moved differently from the torso, land
// nowhere near it. Measured at spawn time, before any model exists: the rigidity trial of young
// models (LifecycleParams::rigidity_trial_frames) only drops a person's model frames later.
#include <cstddef>
#include <vector>

#include <Eigen/Geometry>

#include "common/intrinsics.h"

namespace cofusion::slam {

struct RegionRigidityParams {
  bool enabled = true;
  // Every step-th pixel of the region takes part (pixels in row-major order).
  int step = 2;
  int iterations = 20;  // Gauss-Newton steps of the alignment
  // A region point is aligned when, after the alignment, it lands on a previous-frame pixel with
  // depth and a normal whose point lies within this distance of it (metres): the association
  // radius of the ICP, wide enough for the first frames of a rigid object's motion that the start
  // does not hold (a few centimetres per frame), narrow enough that a swinging limb (10-20 cm per
  // frame at a walk) finds nothing.
  double association_m = 0.1;
  // Residuals beyond this (metres) count down in the alignment (Huber weights).
  double huber_m = 0.01;
  // A region spawns only when at least this fraction of its points that land in the previous
  // view are aligned (0 turns the check off; points that land outside it, where an object enters
  // the view, do not count). Rigid objects measured 0.89-0.98 (the generated scenes' objects, Bonn's
  // and fr1/rpy's static regions), people entering the view 0.48-0.79: the bound lies between.
  double min_aligned_fraction = 0.84;
  // Normals of the previous frame come from its neighbouring pixels; a neighbour more than this
  // far in depth (metres) is across an edge and leaves the pixel without a normal.
  double normal_max_depth_step_m = 0.05;
};

struct RegionRigidity {
  int points = 0;          // region points with depth that took part
  int in_view = 0;         // of them, landing inside the previous image after the alignment
  int aligned = 0;         // of those, aligned (RegionRigidityParams::association_m)
  Eigen::Isometry3d T_previous_current = Eigen::Isometry3d::Identity();  // the alignment found
  double aligned_fraction() const { return in_view > 0 ? double(aligned) / double(in_view) : 0.0; }
};

// Aligns the region's points (`pixels`: indices into the current frame, row-major) to the previous
// frame's depth, starting from `T_previous_current_guess` (current camera -> previous camera, e.g.
// the camera's motion). Depths: width*height metres of the size `intrinsics` gives, 0 or NaN = no
// reading.
RegionRigidity region_rigidity(const float* depth_current_m, const float* depth_previous_m, const Intrinsics& intrinsics,
                               const std::vector<size_t>& pixels, const Eigen::Isometry3d& T_previous_current_guess,
                               const RegionRigidityParams& params);

}  // namespace cofusion::slam
