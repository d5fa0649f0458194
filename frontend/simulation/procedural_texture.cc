#include "frontend/simulation/procedural_texture.h"

#include <algorithm>
#include <cmath>

#include <glog/logging.h>

namespace ieslam {
namespace {

// A well-mixing 32-bit integer hash (Chris Wellons' "lowbias32").
uint32_t Mix(uint32_t x) {
  x ^= x >> 16;
  x *= 0x7feb352dU;
  x ^= x >> 15;
  x *= 0x846ca68bU;
  x ^= x >> 16;
  return x;
}

// One avalanche round over distinct odd multiples of the two indices: enough for noise and
// scattering (runs several times per pixel, so it is kept to a single Mix).
uint32_t HashCell(uint32_t seed, int64_t i, int64_t j) {
  return Mix(seed ^ (static_cast<uint32_t>(i) * 0x9E3779B1U) ^
             (static_cast<uint32_t>(j) * 0x85EBCA77U));
}

// Successive uniform numbers in [0, 1) from one cell hash.
class CellRandom {
 public:
  explicit CellRandom(uint32_t hash) : state_(hash) {}
  double Next() {
    state_ = Mix(state_ + 0x9E3779B9U);
    return (state_ >> 8) * (1.0 / 16777216.0);
  }
  double Range(double lo, double hi) { return lo + (hi - lo) * Next(); }

 private:
  uint32_t state_;
};

double Clamp01(double x) { return std::min(1.0, std::max(0.0, x)); }

// Fraction of the interval [x - w/2, x + w/2] inside [lo, hi]: the exact box filter of an
// edge, additive over disjoint intervals.
double IntervalCoverage(double x, double w, double lo, double hi) {
  return Clamp01((std::min(x + 0.5 * w, hi) - std::max(x - 0.5 * w, lo)) / w);
}

// Coverage of a shape with signed distance `sd` (negative inside), to first order.
double SdfCoverage(double sd, double w) { return Clamp01(0.5 - sd / w); }

Eigen::Vector3f HsvToRgb(double h, double s, double v) {
  const double c = v * s;
  const double hp = std::fmod(h, 1.0) * 6.0;
  const double x = c * (1.0 - std::fabs(std::fmod(hp, 2.0) - 1.0));
  double r = 0, g = 0, b = 0;
  if (hp < 1) {
    r = c;
    g = x;
  } else if (hp < 2) {
    r = x;
    g = c;
  } else if (hp < 3) {
    g = c;
    b = x;
  } else if (hp < 4) {
    g = x;
    b = c;
  } else if (hp < 5) {
    r = x;
    b = c;
  } else {
    r = c;
    b = x;
  }
  const double m = v - c;
  return Eigen::Vector3f(static_cast<float>(r + m), static_cast<float>(g + m),
                         static_cast<float>(b + m));
}

// The noise octaves: wavelength (metres), its inverse (no division per pixel), amplitude.
struct Octave {
  double wavelength;
  double frequency;
  double amplitude;
};
constexpr Octave kOctaves[5] = {{0.6, 1.0 / 0.6, 0.35},
                                {0.25, 1.0 / 0.25, 0.3},
                                {0.1, 1.0 / 0.1, 0.25},
                                {0.045, 1.0 / 0.045, 0.2},
                                {0.02, 1.0 / 0.02, 0.15}};

// Sum of the first `octaves` noise octaves, each faded out as its lattice spacing (the
// "wavelength") approaches the footprint: fully present at >= 2 footprints, gone at <= 1.
// Value noise keeps most of its energy at wavelengths of twice its spacing and more, so
// this removes what would alias and little else.
double FilteredNoise(uint32_t seed, const Eigen::Vector2d& st, double inverse_w, int octaves) {
  double sum = 0.0;
  for (int k = 0; k < octaves; ++k) {
    const Octave& o = kOctaves[k];
    const double fade = Clamp01(o.wavelength * inverse_w - 1.0);
    if (fade <= 0.0) continue;
    const double n = ValueNoise(seed + 7919U * static_cast<uint32_t>(k), st.x() * o.frequency,
                                st.y() * o.frequency);
    sum += fade * o.amplitude * (n - 0.5);
  }
  return sum;
}

// At most one shape per cell, kept inside its cell so that only the cell holding the point
// needs looking at. Blends the shape's colour over `rgb`.
void BlendShape(uint32_t seed, double cell, float probability, const Eigen::Vector2d& st, double w,
                Eigen::Vector3f* rgb) {
  const double ci = std::floor(st.x() / cell), cj = std::floor(st.y() / cell);
  CellRandom random(HashCell(seed, static_cast<int64_t>(ci), static_cast<int64_t>(cj)));
  if (random.Next() >= probability) return;
  const double kind = random.Next();
  const double radius = random.Range(0.12, 0.38) * cell;  // bounding radius
  const double cx = (ci + 0.5) * cell + random.Range(-1.0, 1.0) * (0.5 * cell - radius);
  const double cy = (cj + 0.5) * cell + random.Range(-1.0, 1.0) * (0.5 * cell - radius);
  const double hue = random.Next(), saturation = random.Range(0.3, 1.0);
  const double value = random.Range(0.05, 1.0);
  const double dx = st.x() - cx, dy = st.y() - cy;
  double coverage = 0.0, area = 0.0;
  if (kind < 0.35) {  // disc
    coverage = SdfCoverage(std::sqrt(dx * dx + dy * dy) - radius, w);
    area = M_PI * radius * radius;
  } else if (kind < 0.5) {  // ring
    const double thickness = random.Range(0.2, 0.45) * radius;
    coverage =
        SdfCoverage(std::fabs(std::sqrt(dx * dx + dy * dy) - (radius - thickness)) - thickness, w);
    area = 4.0 * M_PI * (radius - thickness) * thickness;
  } else if (kind < 0.75) {  // axis-aligned rectangle: exact box filter
    const double hx = radius * random.Range(0.35, 0.7), hy = radius * random.Range(0.35, 0.7);
    coverage = IntervalCoverage(dx, w, -hx, hx) * IntervalCoverage(dy, w, -hy, hy);
    area = 4.0 * hx * hy;
  } else {  // rotated rectangle
    // A random direction in the upper half plane, without trigonometry (this runs per pixel).
    const double c = random.Range(-1.0, 1.0), s = std::sqrt(1.0 - c * c);
    const double hx = radius * random.Range(0.4, 0.7), hy = radius * random.Range(0.2, 0.7);
    const double qx = std::fabs(c * dx + s * dy) - hx, qy = std::fabs(-s * dx + c * dy) - hy;
    const double outside = std::hypot(std::max(qx, 0.0), std::max(qy, 0.0));
    coverage = SdfCoverage(outside + std::min(std::max(qx, qy), 0.0), w);
    area = 4.0 * hx * hy;
  }
  // A shape smaller than the footprint cannot cover more of it than its own area: without
  // this cap the first-order coverage would keep tiny shapes at full contrast far away.
  coverage = std::min(coverage, area / (w * w));
  if (coverage > 0.0) {
    *rgb += static_cast<float>(coverage) * (HsvToRgb(hue, saturation, value) - *rgb);
  }
}

// Text-like blocks: a light panel with rows of 3x5-dot glyphs, ragged line ends, spaces.
void BlendText(const SurfaceTexture& texture, const Eigen::Vector2d& st, double w,
               Eigen::Vector3f* rgb) {
  const double cell = texture.text_block_cell_m;
  const double ci = std::floor(st.x() / cell), cj = std::floor(st.y() / cell);
  const uint32_t block_hash =
      HashCell(texture.seed ^ 0xA5A5A5A5U, static_cast<int64_t>(ci), static_cast<int64_t>(cj));
  CellRandom random(block_hash);
  if (random.Next() >= texture.text_probability) return;
  const double width = random.Range(0.35, 0.7) * cell, height = random.Range(0.25, 0.55) * cell;
  const double x0 = ci * cell + random.Range(0.05, 0.95) * (cell - width);
  const double y0 = cj * cell + random.Range(0.05, 0.95) * (cell - height);
  const double bx = st.x() - x0, by = st.y() - y0;
  const double panel = IntervalCoverage(bx, w, 0.0, width) * IntervalCoverage(by, w, 0.0, height);
  if (panel <= 0.0) return;
  const Eigen::Vector3f paper =
      HsvToRgb(random.Next(), random.Range(0.0, 0.25), random.Range(0.8, 0.95));
  const Eigen::Vector3f ink =
      HsvToRgb(random.Next(), random.Range(0.0, 0.8), random.Range(0.0, 0.3));
  const double line_height = random.Range(0.035, 0.065);
  const double glyph_width = 0.75 * line_height;
  const double margin = 0.6 * line_height;
  *rgb += static_cast<float>(panel) * (paper - *rgb);

  // The glyph cell holding the point; its 3x5 dots fill the middle of the cell, so a small
  // footprint never reaches the neighbouring glyph.
  const double gx = bx - margin, gy = by - margin;
  if (gx < -w || gy < -w || gx > width - 2 * margin + w || gy > height - 2 * margin + w) return;
  const double col = std::floor(gx / glyph_width), line = std::floor(gy / line_height);
  const int columns = static_cast<int>((width - 2 * margin) / glyph_width);
  const int lines = static_cast<int>((height - 2 * margin) / line_height);
  if (col < 0 || line < 0 || line >= lines) return;
  CellRandom line_random(HashCell(block_hash, static_cast<int64_t>(line), -1));
  const int line_length = static_cast<int>(columns * line_random.Range(0.4, 1.0));
  if (col >= line_length) return;
  CellRandom glyph(HashCell(block_hash, static_cast<int64_t>(line), static_cast<int64_t>(col)));
  if (glyph.Next() < 0.15) return;  // a space
  const double dot_w = glyph_width * 0.7 / 3.0, dot_h = line_height * 0.7 / 5.0;
  const double lx = gx - col * glyph_width - 0.15 * glyph_width;
  const double ly = gy - line * line_height - 0.15 * line_height;
  double coverage = 0.0;
  for (int r = 0; r < 5; ++r) {
    const double cover_y = IntervalCoverage(ly, w, r * dot_h, (r + 1) * dot_h);
    if (cover_y <= 0.0) {
      for (int c = 0; c < 3; ++c) glyph.Next();  // keep the dot pattern independent of w
      continue;
    }
    for (int c = 0; c < 3; ++c) {
      if (glyph.Next() < 0.45) continue;
      coverage += cover_y * IntervalCoverage(lx, w, c * dot_w, (c + 1) * dot_w);
    }
  }
  coverage = std::min(coverage, 1.0) * panel;
  if (coverage > 0.0) *rgb += static_cast<float>(coverage) * (ink - *rgb);
}

}  // namespace

double ValueNoise(uint32_t seed, double x, double y) {
  const double fx = std::floor(x), fy = std::floor(y);
  const int64_t i = static_cast<int64_t>(fx), j = static_cast<int64_t>(fy);
  const double tx = x - fx, ty = y - fy;
  // Quintic fade: C2-continuous, so the noise has no visible grid.
  const double sx = tx * tx * tx * (tx * (tx * 6 - 15) + 10);
  const double sy = ty * ty * ty * (ty * (ty * 6 - 15) + 10);
  auto corner = [seed](int64_t a, int64_t b) {
    return (HashCell(seed, a, b) >> 8) * (1.0 / 16777215.0);
  };
  const double v00 = corner(i, j), v10 = corner(i + 1, j);
  const double v01 = corner(i, j + 1), v11 = corner(i + 1, j + 1);
  const double top = v00 + sx * (v10 - v00), bottom = v01 + sx * (v11 - v01);
  return top + sy * (bottom - top);
}

SurfaceTexture RandomSurfaceTexture(bool allow_text, std::mt19937* rng) {
  CHECK(rng != nullptr);
  std::uniform_real_distribution<double> u(0.0, 1.0);
  SurfaceTexture t;
  t.seed = (*rng)();
  const double hue = u(*rng), saturation = 0.1 + 0.5 * u(*rng), value = 0.45 + 0.4 * u(*rng);
  t.base_rgb = HsvToRgb(hue, saturation, value);
  t.noise_contrast = static_cast<float>(0.5 + 0.5 * u(*rng));
  t.tint_contrast = static_cast<float>(0.1 + 0.3 * u(*rng));
  t.large_shape_cell_m = 0.25 + 0.25 * u(*rng);
  t.small_shape_cell_m = 0.08 + 0.08 * u(*rng);
  t.shape_probability = static_cast<float>(0.4 + 0.4 * u(*rng));
  t.text_block_cell_m = 1.0 + 0.6 * u(*rng);
  t.text_probability = allow_text ? static_cast<float>(0.3 + 0.4 * u(*rng)) : 0.0f;
  return t;
}

Eigen::Vector3f EvaluateTexture(const SurfaceTexture& texture, const Eigen::Vector2d& st_m,
                                double footprint_m) {
  CHECK_GT(footprint_m, 0.0);
  const double w = footprint_m, inverse_w = 1.0 / footprint_m;
  const double brightness =
      1.0 + texture.noise_contrast * 2.0 * FilteredNoise(texture.seed, st_m, inverse_w, 5);
  Eigen::Vector3f rgb = texture.base_rgb * static_cast<float>(brightness);
  // Tint along two opponent-colour axes (red-cyan, blue-yellow) at the coarsest scale only:
  // colour variation for the eye rather than detail for the detector.
  const double red = FilteredNoise(texture.seed + 101U, st_m, inverse_w, 1);
  const double blue = FilteredNoise(texture.seed + 202U, st_m, inverse_w, 1);
  const double k = texture.tint_contrast * 4.0;
  rgb += Eigen::Vector3f(static_cast<float>(k * (red - 0.5 * blue)),
                         static_cast<float>(k * (-0.5 * red - 0.5 * blue)),
                         static_cast<float>(k * (blue - 0.5 * red)));
  BlendShape(texture.seed ^ 0x1234567U, texture.large_shape_cell_m, texture.shape_probability, st_m,
             w, &rgb);
  BlendShape(texture.seed ^ 0x7654321U, texture.small_shape_cell_m, texture.shape_probability, st_m,
             w, &rgb);
  if (texture.text_probability > 0.0f) BlendText(texture, st_m, w, &rgb);
  return rgb.cwiseMax(0.0f).cwiseMin(1.0f);
}

}  // namespace ieslam
