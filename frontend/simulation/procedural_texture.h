// Procedural surface textures for the synthetic scene (frontend/simulation/synthetic_scene.h): what
// a feature detector needs to lock onto, as a pure function of a surface's own 2-D coordinates
// (metres) and a seed.
//
// A texture is three layers over a base colour:
//  - value noise at five scales (0.6 m down to 2 cm) modulating brightness, and at the
//    coarsest scale tinting the colour along two opponent-colour axes;
//  - random shapes (discs, rings, rotated rectangles in varied colours) scattered on two
//    grids of different cell size, so that blobs exist at several scales;
//  - optionally text-like blocks: light panels carrying rows of glyph-like dot patterns.
//
// Anti-aliasing (SIFT hates aliasing): the caller passes the footprint of its pixel on the
// surface, `footprint_m`. Noise octaves finer than ~2 footprints fade out; shape and glyph
// edges are box-filtered over the footprint (exactly for axis-aligned rectangles, to first
// order for discs and rotated shapes). One sample per pixel is then free of texture aliasing.
//
// Everything is integer hashing of cell indices and the seed: deterministic across runs,
// platforms and threads, with no state.
#pragma once

#include <cstdint>
#include <random>

#include <Eigen/Core>

namespace ieslam {

struct SurfaceTexture {
  uint32_t seed = 0;
  Eigen::Vector3f base_rgb{0.6f, 0.6f, 0.6f};  // linear-ish RGB in [0, 1]
  float noise_contrast = 0.5f;                 // brightness modulation of the noise layers
  float tint_contrast = 0.2f;                  // colour modulation of the coarse noise
  double large_shape_cell_m = 0.35;            // cell size of the large-shape grid
  double small_shape_cell_m = 0.12;            // cell size of the small-shape grid
  float shape_probability = 0.6f;              // chance that a cell holds a shape
  double text_block_cell_m = 1.3;              // each cell of this size may hold a text block
  float text_probability = 0.0f;               // chance that a block cell holds text
};

// A random texture: colours, contrasts and shape densities drawn from `rng`. Text blocks are
// only put on surfaces with `allow_text` (walls, boxes' sides, panels; not the floor).
SurfaceTexture RandomSurfaceTexture(bool allow_text, std::mt19937* rng);

// The colour at texture coordinates `st_m` (metres), box-filtered over a square footprint of
// side `footprint_m` (> 0). Components in [0, 1].
Eigen::Vector3f EvaluateTexture(const SurfaceTexture& texture, const Eigen::Vector2d& st_m,
                                double footprint_m);

// Smooth value noise in [0, 1] with unit cell size (exposed for tests).
double ValueNoise(uint32_t seed, double x, double y);

}  // namespace ieslam
