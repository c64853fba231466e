// Test support: the hand-checked two-cell scene profile. Camera rays enter cell 0
// (alpha 0.5, beta 0.5, misses go to cell 1); cell 1 lets every ray escape; shadow rays
// are never occluded and never leave their cell.
#pragma once
#include "workload/scene_profile.hpp"

namespace rayline::testing {

inline SceneProfile two_cell_profile(int max_bounces) {
  SceneProfile p;
  p.max_bounces = max_bounces;
  p.blocks.resize(2);
  p.blocks[0].alpha = 0.5;
  p.blocks[0].beta = 0.5;
  p.blocks[0].neighbours = {{1, 1.0, 1.0}};
  p.blocks[1].alpha = 0;
  p.blocks[1].escape = 1;
  p.blocks[1].neighbours = {{0, 1.0, 1.0}};
  p.camera_path = {CameraKey{{{0, 1.0}}, 0}};
  return p;
}

}  // namespace rayline::testing
