#include "tsf/segment/sinus_anatomy.h"

#include <algorithm>
#include <array>
#include <cmath>
#include <cstdint>
#include <cstdio>
#include <limits>
#include <string>
#include <vector>

#include "tsf/volume/tissue_labels.h"

namespace tsf::segment {

namespace {

constexpr double kBandMm = 15.0;              // nasal cavity: |x − mid| within this
constexpr double kMinNoseProtrusionMm = 8.0;  // a nose protrudes beyond the cheeks (15–35 mm)
constexpr double kNostrilDepthMm = 10.0;      // a nostril: the front of its opening
constexpr double kNoseTipDepthMm = 2.0;       // the nose tip: the front of the nose
constexpr double kOpeningBandMm = 20.0;       // nostril openings: |x − mid| within this
constexpr double kMaxHeadAirMl = 250.0;       // more air inside the body than a head holds
constexpr double kMinNasalCavityMl = 1.0;     // less is not a nasal cavity
constexpr double kMinParanasalMl = 0.3;       // less is reported as not found

std::string fmt(double v, int decimals = 1) {
  char buf[64];
  std::snprintf(buf, sizeof buf, "%.*f", decimals, v);
  return buf;
}

double clamp01(double v) {
  return std::clamp(v, 0.0, 1.0);
}

/// The grid and the patient-direction coordinates of its voxels: lateral (mm toward left from
/// the midsagittal plane), anterior (mm toward the detected face), superior (mm up).
struct Grid {
  int n[3]{};
  double s = 1.0;
  double origin[3]{};
  double dir[3][3]{};  // dir[r][c]: column c = index axis c in LPS
  int a_lr = 0, a_ap = 1, a_si = 2;
  int sign_lr = 1, sign_si = 1, sign_face = 1;

  std::size_t index(int i, int j, int k) const {
    return static_cast<std::size_t>(i) +
           static_cast<std::size_t>(n[0]) *
               (static_cast<std::size_t>(j) + static_cast<std::size_t>(n[1]) * k);
  }
  Vec3d physical(double i, double j, double k) const {
    const double c[3] = {i * s, j * s, k * s};
    Vec3d p;
    for (int r = 0; r < 3; ++r)
      p[r] = origin[r] + dir[r][0] * c[0] + dir[r][1] * c[1] + dir[r][2] * c[2];
    return p;
  }
  void unindex(std::size_t v, int idx[3]) const {
    idx[0] = static_cast<int>(v % n[0]);
    idx[1] = static_cast<int>((v / n[0]) % n[1]);
    idx[2] = static_cast<int>(v / (static_cast<std::size_t>(n[0]) * n[1]));
  }
  /// Breadth-first growth over face neighbours: every voxel of `queue` (from `first` on) offers
  /// its in-grid neighbours w (index widx); one with mark[w] == 0 and accept(w, widx) is marked
  /// and queued, and grows in turn. The one flood fill of this file.
  template <class Accept>
  void flood(std::vector<std::uint32_t>& queue, std::vector<unsigned char>& mark, Accept accept,
             std::size_t first = 0) const {
    const std::ptrdiff_t step[3] = {1, n[0], static_cast<std::ptrdiff_t>(n[0]) * n[1]};
    for (std::size_t q = first; q < queue.size(); ++q) {
      const std::size_t v = queue[q];
      int idx[3];
      unindex(v, idx);
      for (int a = 0; a < 3; ++a)
        for (int d = -1; d <= 1; d += 2) {
          if (idx[a] + d < 0 || idx[a] + d >= n[a]) continue;
          const std::size_t w = v + d * step[a];
          if (mark[w]) continue;
          int widx[3] = {idx[0], idx[1], idx[2]};
          widx[a] += d;
          if (!accept(w, widx)) continue;
          mark[w] = 1;
          queue.push_back(static_cast<std::uint32_t>(w));
        }
    }
  }
  Vec3d column(int c) const { return {dir[0][c], dir[1][c], dir[2][c]}; }
  // The midsagittal plane (point, unit normal toward left) and the anterior and superior axes.
  Vec3d plane_p, plane_n{1, 0, 0}, ant_axis{0, -1, 0}, sup_axis{0, 0, 1};
  double lat(const int idx[3]) const {
    return dot(physical(idx[0], idx[1], idx[2]) - plane_p, plane_n);
  }
  double ant(const int idx[3]) const {
    return dot(physical(idx[0], idx[1], idx[2]), ant_axis) * sign_face;
  }
  double sup(const int idx[3]) const { return dot(physical(idx[0], idx[1], idx[2]), sup_axis); }
  /// The voxel nearest to an LPS point, or false outside the grid.
  bool nearest(const Vec3d& p, int idx[3]) const {
    for (int c = 0; c < 3; ++c) {
      const double t = (dir[0][c] * (p.x - origin[0]) + dir[1][c] * (p.y - origin[1]) +
                        dir[2][c] * (p.z - origin[2])) /
                       s;
      idx[c] = static_cast<int>(std::lround(t));
      if (idx[c] < 0 || idx[c] >= n[c]) return false;
    }
    return true;
  }
};

/// Bounding box, centroid and volume of a set of voxels, in LPS.
struct Accumulator {
  std::size_t count = 0;
  Vec3d lo{std::numeric_limits<double>::max(), std::numeric_limits<double>::max(),
           std::numeric_limits<double>::max()};
  Vec3d hi{std::numeric_limits<double>::lowest(), std::numeric_limits<double>::lowest(),
           std::numeric_limits<double>::lowest()};
  Vec3d sum{0, 0, 0};
  void add(const Vec3d& p) {
    ++count;
    for (int a = 0; a < 3; ++a) {
      lo[a] = std::min(lo[a], p[a]);
      hi[a] = std::max(hi[a], p[a]);
    }
    sum = sum + p;
  }
  void fill(AnatomyRegion& r, double voxel_ml) const {
    r.ml = static_cast<double>(count) * voxel_ml;
    if (count == 0) return;
    r.min_mm = lo;
    r.max_mm = hi;
    r.centroid_mm = sum * (1.0 / static_cast<double>(count));
  }
};

int dominant_axis(const double dir[3][3], int row, int avoid1, int avoid2) {
  int best = -1;
  for (int c = 0; c < 3; ++c) {
    if (c == avoid1 || c == avoid2) continue;
    if (best < 0 || std::abs(dir[row][c]) > std::abs(dir[row][best])) best = c;
  }
  return best;
}

}  // namespace

const AnatomyRegion* SinusAnatomy::region(const std::string& name) const {
  for (const AnatomyRegion& r : regions)
    if (r.name == name) return &r;
  return nullptr;
}

const AnatomyLandmark* SinusAnatomy::landmark(const std::string& name) const {
  for (const AnatomyLandmark& l : landmarks)
    if (l.name == name) return &l;
  return nullptr;
}

SinusAnatomy find_sinus_anatomy(const SegmentationImages& images,
                                const SinusAnatomyOptions& options) {
  SinusAnatomy out;
  out.frame.orientation_recorded = options.orientation_recorded;
  out.midsagittal.name = "midsagittal";
  for (const char* name :
       {"nasal-cavity", "maxillary-left", "maxillary-right", "frontal", "sphenoid", "ethmoid"}) {
    AnatomyRegion r;
    r.name = name;
    out.regions.push_back(r);
  }
  for (const char* name : {"nose-tip", "nostril-left", "nostril-right"}) {
    AnatomyLandmark l;
    l.name = name;
    out.landmarks.push_back(l);
  }
  AnatomyRegion& nasal = out.regions[0];
  AnatomyLandmark& tip = out.landmarks[0];

  const HuImage* hu = images.hu;
  if (!hu || !images.labels || !images.body || !images.air_spaces) {
    out.warnings.push_back(
        "anatomy: the segmentation has no body mask or air spaces: nothing found");
    return out;
  }
  Grid g;
  const auto size = hu->GetLargestPossibleRegion().GetSize();
  for (int a = 0; a < 3; ++a) {
    g.n[a] = static_cast<int>(size[a]);
    g.origin[a] = hu->GetOrigin()[a];
    for (int c = 0; c < 3; ++c) g.dir[a][c] = hu->GetDirection()[a][c];
  }
  g.s = hu->GetSpacing()[0];
  g.a_lr = dominant_axis(g.dir, 0, -1, -1);
  g.a_ap = dominant_axis(g.dir, 1, g.a_lr, -1);
  g.a_si = 3 - g.a_lr - g.a_ap;
  g.sign_lr = g.dir[0][g.a_lr] >= 0 ? 1 : -1;
  g.sign_si = g.dir[2][g.a_si] >= 0 ? 1 : -1;
  const double voxel_ml = g.s * g.s * g.s / 1000.0;

  const unsigned char* labels = images.labels->GetBufferPointer();
  const unsigned char* body = images.body->GetBufferPointer();
  const unsigned char* air = images.air_spaces->GetBufferPointer();
  const std::size_t n = static_cast<std::size_t>(g.n[0]) * g.n[1] * g.n[2];

  std::size_t tissue_count = 0, bone_count = 0, air_count = 0;
  for (std::size_t v = 0; v < n; ++v) {
    tissue_count += is_tissue_label(labels[v]) ? 1 : 0;
    bone_count += is_bone_label(labels[v]) ? 1 : 0;
    air_count += air[v] ? 1 : 0;
  }
  const double air_ml = static_cast<double>(air_count) * voxel_ml;
  if (tissue_count == 0) {
    out.warnings.push_back("anatomy: no tissue in the segmentation: nothing found");
    return out;
  }

  // ---- midsagittal plane: the mirror offset along the L/R axis with the best overlap --------
  {
    const bool use_bone = bone_count >= 1000;
    auto in_mask = [&](std::size_t v) {
      return use_bone ? is_bone_label(labels[v]) : is_tissue_label(labels[v]);
    };
    const std::size_t total = use_bone ? bone_count : tissue_count;
    const std::size_t stride = std::max<std::size_t>(1, total / 100000);
    std::vector<Vec3d> pts;
    Vec3d c{0, 0, 0};
    std::size_t seen = 0;
    for (int k = 0; k < g.n[2]; ++k)
      for (int j = 0; j < g.n[1]; ++j)
        for (int i = 0; i < g.n[0]; ++i) {
          if (!in_mask(g.index(i, j, k))) continue;
          if (seen++ % stride) continue;
          pts.push_back(g.physical(i, j, k));
          c = c + pts.back();
        }
    c = c * (1.0 / static_cast<double>(pts.size()));
    // Mirror planes through c + d·n, n turned by θ about the superior axis from the L/R axis
    // (a head may lie yawed in the scanner): 3° steps, then 1°, then 0.25° around the best.
    const Vec3d lr = g.column(g.a_lr) * static_cast<double>(g.sign_lr);
    const Vec3d ap = g.column(g.a_ap);
    constexpr double kDeg = 3.14159265358979323846 / 180.0;
    auto normal_at = [&](double theta) {
      return lr * std::cos(theta * kDeg) + ap * std::sin(theta * kDeg);
    };
    auto overlap = [&](double theta, double d) {
      const Vec3d nrm = normal_at(theta);
      std::size_t hit = 0;
      int idx[3];
      for (const Vec3d& p : pts) {
        const Vec3d q = p - nrm * (2.0 * (dot(p - c, nrm) - d));
        if (g.nearest(q, idx)) hit += in_mask(g.index(idx[0], idx[1], idx[2])) ? 1 : 0;
      }
      return static_cast<double>(hit) / static_cast<double>(pts.size());
    };
    double best_theta = 0.0, best_d = 0.0, best_overlap = -1.0;
    const double d_step = std::max(1.0, g.s);
    // The best (θ, d) of a grid of yaw angles and offsets, starting from the best so far.
    auto search = [&](double theta0, double theta1, double theta_step, double d0, double d1,
                      double d_step_here) {
      for (double theta = theta0; theta <= theta1 + 1e-9; theta += theta_step)
        for (double d = d0; d <= d1 + 1e-9; d += d_step_here) {
          const double o = overlap(theta, d);
          if (o > best_overlap + 1e-6) {
            best_overlap = o;
            best_theta = theta;
            best_d = d;
          }
        }
    };
    search(-30.0, 30.0, 3.0, -15.0, 15.0, d_step);
    const double coarse_theta = best_theta, coarse_d = best_d;
    search(coarse_theta - 2.0, coarse_theta + 2.0, 1.0, coarse_d - d_step, coarse_d + d_step,
           0.25 * d_step);
    const double fine_theta = best_theta, fine_d = best_d;
    search(fine_theta - 0.75, fine_theta + 0.75, 0.25, fine_d - 0.5 * d_step, fine_d + 0.5 * d_step,
           0.25 * d_step);
    g.plane_n = normal_at(best_theta);
    g.plane_p = c + g.plane_n * best_d;
    const Vec3d ant0 = ap - g.plane_n * dot(ap, g.plane_n);
    g.ant_axis = ant0 * (1.0 / std::sqrt(length_squared(ant0)));
    g.sup_axis = g.column(g.a_si) * static_cast<double>(g.sign_si);
    AnatomyPlane& m = out.midsagittal;
    m.found = true;
    m.point_mm = g.plane_p;
    m.normal = g.plane_n;
    m.confidence = clamp01((best_overlap - 0.2) / 0.5) * (use_bone ? 1.0 : 0.7);
    m.reason = std::string("left-right mirror plane of the ") + (use_bone ? "bone" : "tissue") +
               ", turned " + fmt(best_theta, 1) +
               " deg about the vertical: " + fmt(100.0 * best_overlap, 0) +
               " % of its voxels have a mirror image";
  }

  // ---- facing: which end of the A/P axis the face is at ---------------------------------------
  {
    int lo = g.n[g.a_ap], hi = -1;
    double sum_t = 0, sum_a = 0;
    for (int k = 0; k < g.n[2]; ++k)
      for (int j = 0; j < g.n[1]; ++j)
        for (int i = 0; i < g.n[0]; ++i) {
          const std::size_t v = g.index(i, j, k);
          const int idx[3] = {i, j, k};
          if (is_tissue_label(labels[v])) {
            lo = std::min(lo, idx[g.a_ap]);
            hi = std::max(hi, idx[g.a_ap]);
            sum_t += idx[g.a_ap];
          }
          if (air[v]) sum_a += idx[g.a_ap];
        }
    const int cap = static_cast<int>(std::lround(15.0 / g.s));
    std::size_t cap_lo = 0, cap_hi = 0;
    for (int k = 0; k < g.n[2]; ++k)
      for (int j = 0; j < g.n[1]; ++j)
        for (int i = 0; i < g.n[0]; ++i) {
          if (!is_tissue_label(labels[g.index(i, j, k)])) continue;
          const int idx[3] = {i, j, k};
          if (idx[g.a_ap] <= lo + cap) ++cap_lo;
          if (idx[g.a_ap] >= hi - cap) ++cap_hi;
        }
    // Nose vote: the end with the smaller 15 mm cap of tissue (the nose protrudes; the back of
    // the head is round). Air vote: the air spaces lie in front of the tissue's centre.
    int nose_vote = 0, air_vote = 0;
    const double cap_ratio =
        static_cast<double>(std::min(cap_lo, cap_hi)) /
        static_cast<double>(std::max<std::size_t>(1, std::max(cap_lo, cap_hi)));
    if (cap_ratio < 0.7) nose_vote = cap_hi < cap_lo ? 1 : -1;
    double air_shift_mm = 0.0;
    if (air_count > 0) {
      air_shift_mm =
          (sum_a / static_cast<double>(air_count) - sum_t / static_cast<double>(tissue_count)) *
          g.s;
      if (std::abs(air_shift_mm) > 10.0) air_vote = air_shift_mm > 0 ? 1 : -1;
    }
    // The recorded frame's anterior (−y) along this index axis.
    const int recorded = g.dir[1][g.a_ap] >= 0 ? -1 : 1;
    std::string evidence = "the 15 mm cap of tissue is " + fmt(100.0 * cap_ratio, 0) +
                           " % of the other end's; the air spaces lie " +
                           fmt(std::abs(air_shift_mm), 0) + " mm off the tissue's centre";
    if (nose_vote != 0 && nose_vote == air_vote) {
      g.sign_face = nose_vote;
      out.frame.facing_confidence = 0.9;
      out.frame.facing_reason =
          "the nose protrudes and the air spaces lie in front (" + evidence + ")";
    } else if (nose_vote != 0 && air_vote == 0) {
      g.sign_face = nose_vote;
      out.frame.facing_confidence = 0.65;
      out.frame.facing_reason = "the nose protrudes (" + evidence + ")";
    } else if (nose_vote == 0 && air_vote != 0) {
      g.sign_face = air_vote;
      out.frame.facing_confidence = 0.55;
      out.frame.facing_reason = "the air spaces lie in front (" + evidence + ")";
    } else if (nose_vote != 0) {
      g.sign_face = nose_vote;
      out.frame.facing_confidence = 0.4;
      out.frame.facing_reason =
          "the nose protrudes but the air spaces lie behind (" + evidence + ")";
    } else {
      g.sign_face = recorded;
      out.frame.facing_confidence = 0.2;
      out.frame.facing_reason =
          "no protruding nose and no air spaces in front: the frame's anterior (−y) is assumed (" +
          evidence + ")";
    }
    if (options.orientation_recorded && g.sign_face != recorded &&
        out.frame.facing_confidence < 0.9) {
      // A recorded frame is the scanner's word for where the face is; weak image evidence
      // against it more likely means the CT shows no face (a phantom, a partial or non-head scan)
      // than a wrong header, so the recorded frame is kept and the doubt is said.
      out.warnings.push_back(
          "anatomy: the image's evidence for the face's side (" + out.frame.facing_reason +
          ", confidence " + fmt(out.frame.facing_confidence, 2) +
          ") contradicts the recorded patient frame, which is used: this CT may not show a face "
          "(a phantom, a partial or non-head scan)");
      g.sign_face = recorded;
      out.frame.facing_confidence = 0.3;
      out.frame.facing_reason =
          "the recorded frame's anterior (−y); the image's evidence points "
          "the other way (" +
          evidence + ")";
    }
    out.frame.anterior = g.ant_axis * static_cast<double>(g.sign_face);
    out.frame.left = g.plane_n;
    out.frame.superior = g.sup_axis;
    out.frame.facing_agrees = g.sign_face == recorded;
    if (!out.frame.facing_agrees)
      out.warnings.push_back(
          "anatomy: the face points toward " + std::string(out.frame.anterior.y > 0 ? "+y" : "-y") +
          ", which is posterior in the " +
          (options.orientation_recorded ? "recorded" : "assumed (L, P, S)") +
          " patient frame (confidence " + fmt(out.frame.facing_confidence, 2) +
          "): the anatomy uses the detected facing for anterior/posterior" +
          (options.orientation_recorded ? "" : "; left/right is not recorded and taken as +x"));
  }

  // ---- outside air: flood the air (labels outside) from the air outside the body -------------
  std::vector<unsigned char> reached(n, 0);
  {
    std::vector<std::uint32_t> queue;
    const int step[3] = {1, g.n[0], g.n[0] * g.n[1]};
    for (int k = 0; k < g.n[2]; ++k)
      for (int j = 0; j < g.n[1]; ++j)
        for (int i = 0; i < g.n[0]; ++i) {
          const std::size_t v = g.index(i, j, k);
          if (body[v] || labels[v] != kLabelOutside) continue;
          reached[v] = 1;
          const int idx[3] = {i, j, k};
          for (int a = 0; a < 3; ++a) {
            if ((idx[a] > 0 && body[v - step[a]]) || (idx[a] + 1 < g.n[a] && body[v + step[a]])) {
              queue.push_back(static_cast<std::uint32_t>(v));
              break;
            }
          }
        }
    g.flood(queue, reached, [&](std::size_t w, const int*) { return labels[w] == kLabelOutside; });
  }

  // ---- openings: air-space voxels next to reached air that is not air space, at the front ----
  struct Opening {
    int idx[3];
    double lat, ant, sup;
  };
  std::vector<Opening> openings;
  double tissue_ant_lo = std::numeric_limits<double>::max(), tissue_ant_hi = -tissue_ant_lo;
  {
    const int step[3] = {1, g.n[0], g.n[0] * g.n[1]};
    for (int k = 0; k < g.n[2]; ++k)
      for (int j = 0; j < g.n[1]; ++j)
        for (int i = 0; i < g.n[0]; ++i) {
          const std::size_t v = g.index(i, j, k);
          const int idx[3] = {i, j, k};
          if (is_tissue_label(labels[v])) {
            tissue_ant_lo = std::min(tissue_ant_lo, g.ant(idx));
            tissue_ant_hi = std::max(tissue_ant_hi, g.ant(idx));
          }
          if (!air[v] || !reached[v]) continue;
          bool open = false;
          for (int a = 0; a < 3 && !open; ++a)
            for (int d = -1; d <= 1 && !open; d += 2) {
              if (idx[a] + d < 0 || idx[a] + d >= g.n[a]) continue;
              const std::size_t w = v + static_cast<std::ptrdiff_t>(d) * step[a];
              open = reached[w] && !air[w];
            }
          if (open) openings.push_back({{i, j, k}, g.lat(idx), g.ant(idx), g.sup(idx)});
        }
  }
  const double ant_centre = 0.5 * (tissue_ant_lo + tissue_ant_hi);
  // A first nose tip: the most anterior tissue near the midline, at any height.
  double tip0[3] = {0, 0, 0};
  {
    double best = -std::numeric_limits<double>::max();
    std::size_t ties = 0;
    for (int k = 0; k < g.n[2]; ++k)
      for (int j = 0; j < g.n[1]; ++j)
        for (int i = 0; i < g.n[0]; ++i) {
          if (!is_tissue_label(labels[g.index(i, j, k)])) continue;
          const int idx[3] = {i, j, k};
          if (std::abs(g.lat(idx)) > kBandMm) continue;
          const double a = g.ant(idx);
          if (a > best + 1e-9) {
            best = a;
            ties = 0;
            tip0[0] = tip0[1] = tip0[2] = 0;
          }
          if (a >= best - 1e-9) {
            ++ties;
            tip0[0] += g.lat(idx);
            tip0[1] += a;
            tip0[2] += g.sup(idx);
          }
        }
    if (ties > 0)
      for (double& c : tip0) c /= static_cast<double>(ties);
  }
  std::vector<Opening> front;
  for (const Opening& o : openings) {
    const double d =
        std::sqrt((o.lat - tip0[0]) * (o.lat - tip0[0]) + (o.ant - tip0[1]) * (o.ant - tip0[1]) +
                  (o.sup - tip0[2]) * (o.sup - tip0[2]));
    // The nostrils open at or below the nose tip (the eyes lie above it).
    if (o.ant >= ant_centre && std::abs(o.lat) <= kOpeningBandMm && d <= 45.0 &&
        o.sup <= tip0[2] + 5.0)
      front.push_back(o);
  }
  if (!front.empty()) {
    // The highest cluster: the nostrils lie above the mouth.
    double top = -std::numeric_limits<double>::max();
    for (const Opening& o : front) top = std::max(top, o.sup);
    std::vector<Opening> kept;
    for (const Opening& o : front)
      if (o.sup >= top - 15.0) kept.push_back(o);
    front.swap(kept);
  }

  // ---- nasal cavity ---------------------------------------------------------------------------
  std::vector<unsigned char> in_nasal(n, 0);
  const bool too_much_air = air_ml > kMaxHeadAirMl;
  double nostril_sup = 0.0, nostril_ant = 0.0;
  bool nasal_open = false;
  if (too_much_air) {
    nasal.reason = "not reported: " + fmt(air_ml, 0) +
                   " ml of air inside the body is far more than a head's sinuses and nasal "
                   "cavity (20-200 ml)";
    out.warnings.push_back("anatomy: no nasal cavity: the " + fmt(air_ml, 0) +
                           " ml of air inside the body is far more than a head's sinuses and "
                           "nasal cavity hold (20-200 ml): an empty skull, a phantom or not a head "
                           "CT? No air spaces are reported");
  } else if (air_count == 0) {
    nasal.reason = "no air space inside the body";
    out.warnings.push_back(
        "anatomy: no nasal cavity: there is no air space inside the body (no sinuses, no nasal "
        "cavity; a phantom or not a head CT?); nose tip, nostrils and paranasal air spaces are "
        "not found");
  } else {
    std::vector<std::uint32_t> queue;
    auto grow = [&]() {
      g.flood(queue, in_nasal, [&](std::size_t w, const int* widx) {
        return air[w] && std::abs(g.lat(widx)) <= kBandMm && g.sup(widx) <= nostril_sup + 55.0 &&
               g.ant(widx) >= nostril_ant - 80.0;
      });
    };
    // Fallback: the largest air-space component within the midline band, in front of the
    // tissue's centre (the nasal cavity is the largest midline air space of a head).
    auto largest_front_component = [&]() {
      std::vector<unsigned char> seen(n, 0);
      std::vector<std::uint32_t> best, comp;
      for (int k = 0; k < g.n[2]; ++k)
        for (int j = 0; j < g.n[1]; ++j)
          for (int i = 0; i < g.n[0]; ++i) {
            const std::size_t v0 = g.index(i, j, k);
            const int idx0[3] = {i, j, k};
            if (!air[v0] || seen[v0] || std::abs(g.lat(idx0)) > kBandMm || g.ant(idx0) < ant_centre)
              continue;
            comp.assign(1, static_cast<std::uint32_t>(v0));
            seen[v0] = 1;
            g.flood(comp, seen, [&](std::size_t w, const int* widx) {
              return air[w] && std::abs(g.lat(widx)) <= kBandMm && g.ant(widx) >= ant_centre;
            });
            if (comp.size() > best.size()) best.swap(comp);
          }
      double most = -std::numeric_limits<double>::max();
      for (std::uint32_t v : best) {
        in_nasal[v] = 1;
        queue.push_back(v);
        int idx[3];
        g.unindex(v, idx);
        if (g.ant(idx) > most && !nasal_open) {
          most = g.ant(idx);
          nostril_sup = g.sup(idx);
          nostril_ant = g.ant(idx);
        }
      }
    };
    if (!front.empty()) {
      nasal_open = true;
      for (const Opening& o : front) {
        nostril_sup += o.sup;
        nostril_ant += o.ant;
      }
      nostril_sup /= static_cast<double>(front.size());
      nostril_ant /= static_cast<double>(front.size());
      for (const Opening& o : front)
        if (std::abs(o.lat) <= kBandMm) {
          const std::size_t v = g.index(o.idx[0], o.idx[1], o.idx[2]);
          if (!in_nasal[v]) {
            in_nasal[v] = 1;
            queue.push_back(static_cast<std::uint32_t>(v));
          }
        }
      grow();
    }
    bool joined = true;  // the cavity is connected to its openings
    if (static_cast<double>(queue.size()) * voxel_ml < kMinNasalCavityMl) {
      for (std::uint32_t v : queue) in_nasal[v] = 0;
      queue.clear();
      largest_front_component();
      joined = false;
    }
    Accumulator acc;
    for (std::size_t v : queue) {
      const int i = static_cast<int>(v % g.n[0]), j = static_cast<int>((v / g.n[0]) % g.n[1]),
                k = static_cast<int>(v / (static_cast<std::size_t>(g.n[0]) * g.n[1]));
      acc.add(g.physical(i, j, k));
    }
    acc.fill(nasal, voxel_ml);
    if (nasal.ml >= kMinNasalCavityMl) {
      nasal.found = true;
      nasal.confidence = joined ? 0.8 : (nasal_open ? 0.5 : 0.35);
      nasal.reason =
          joined ? "midline air spaces (|x - mid| <= 15 mm) reached from the air in front of the "
                   "face through " +
                       std::to_string(front.size()) + " opening voxels (the nostrils)"
                 : std::string(nasal_open ? "the openings (nostrils) found do not connect to it "
                                            "at this voxel size"
                                          : "not open to the outside air at this voxel size") +
                       ": the largest midline air space in front of the head's centre";
      if (!joined)
        out.warnings.push_back(
            "anatomy: the nasal cavity is not connected to the outside air at "
            "this voxel size; taken as the largest midline air space in "
            "front of the head's centre (confidence " +
            fmt(nasal.confidence, 2) + ")");
    } else {
      nasal.reason = "no air space open to the outside at the front near the midline (" +
                     fmt(air_ml, 1) + " ml of air inside the body)";
      out.warnings.push_back("anatomy: no nasal cavity: " + nasal.reason +
                             "; nose tip, nostrils and paranasal air spaces are not found");
    }
  }

  // ---- nose tip: the most anterior tissue near the midline, at the nostrils' height ----------
  {
    double best = -std::numeric_limits<double>::max();
    double cheek = -std::numeric_limits<double>::max();
    std::vector<std::array<int, 3>> tips;
    const double z_lo = nasal.found ? nostril_sup - 10.0 : -std::numeric_limits<double>::max();
    const double z_hi = nasal.found ? nostril_sup + 25.0 : std::numeric_limits<double>::max();
    for (int k = 0; k < g.n[2]; ++k)
      for (int j = 0; j < g.n[1]; ++j)
        for (int i = 0; i < g.n[0]; ++i) {
          if (!is_tissue_label(labels[g.index(i, j, k)])) continue;
          const int idx[3] = {i, j, k};
          const double z = g.sup(idx);
          if (z < z_lo || z > z_hi) continue;
          const double lat = std::abs(g.lat(idx)), a = g.ant(idx);
          if (lat >= 25.0 && lat <= 45.0) cheek = std::max(cheek, a);
          if (lat > kBandMm) continue;
          if (a > best) best = a;
          if (a >= best - kNoseTipDepthMm) tips.push_back({i, j, k});
        }
    // The tip of a blunt nose is a plateau: the centroid of its front kNoseTipDepthMm does not
    // jump sideways with a fraction of a degree of yaw or a shifted voxel grid.
    tips.erase(std::remove_if(tips.begin(), tips.end(),
                              [&](const std::array<int, 3>& t) {
                                const int idx[3] = {t[0], t[1], t[2]};
                                return g.ant(idx) < best - kNoseTipDepthMm;
                              }),
               tips.end());
    const double protrusion = cheek > -1e300 ? best - cheek : 0.0;
    if (!tips.empty() && nasal.found && out.frame.facing_confidence <= 0.3) {
      tip.reason = "no face: nothing in the image says which side the face is on (" +
                   out.frame.facing_reason +
                   "); this CT may not show a face (a phantom, a partial or non-head scan)";
    } else if (!tips.empty() && nasal.found && protrusion < kMinNoseProtrusionMm) {
      tip.reason = "no nose: the most anterior tissue near the midline protrudes " +
                   fmt(protrusion, 0) + " mm beyond the cheeks (a nose, at least " +
                   fmt(kMinNoseProtrusionMm, 0) +
                   " mm); this CT may not show a face (a phantom, a partial or non-head scan)";
    } else if (!tips.empty() && nasal.found) {
      double c[3] = {0, 0, 0};
      for (const auto& t : tips)
        for (int a = 0; a < 3; ++a) c[a] += t[a];
      for (double& x : c) x /= static_cast<double>(tips.size());
      tip.found = true;
      tip.position_mm = g.physical(c[0], c[1], c[2]);
      tip.confidence = clamp01(0.3 + 0.6 * clamp01(protrusion / 15.0)) * (nasal_open ? 1.0 : 0.7) *
                       (out.frame.facing_confidence >= 0.5 ? 1.0 : 0.6);
      tip.reason =
          "the front 2 mm of the tissue within 15 mm of the midline at the nostrils' height; "
          "protrudes " +
          fmt(protrusion, 0) + " mm beyond the cheeks";
    } else {
      tip.reason =
          "not found: it is looked for at the height of the nasal cavity's openings, and "
          "there is no nasal cavity";
    }
  }

  // ---- nostrils: the openings left and right of the midline ----------------------------------
  for (int side = 0; side < 2; ++side) {
    AnatomyLandmark& l = out.landmarks[1 + side];
    double c[3] = {0, 0, 0};
    std::size_t count = 0;
    // The opening runs back along the passage as far as the air is deep enough to count as an
    // air space, which shifts with the voxel grid; its front (kNostrilDepthMm behind its most
    // anterior voxel) is where the nostril is, and is steadier.
    double front_ant = -std::numeric_limits<double>::max();
    for (const Opening& o : front)
      if ((side == 0) == (o.lat > 0)) front_ant = std::max(front_ant, o.ant);
    if (nasal_open)
      for (const Opening& o : front)
        if ((side == 0) == (o.lat > 0) && o.ant >= front_ant - kNostrilDepthMm) {
          for (int a = 0; a < 3; ++a) c[a] += o.idx[a];
          ++count;
        }
    if (count == 0) {
      l.reason = nasal_open ? "no opening on this side of the midline at this voxel size"
                            : "the nasal cavity is not open to the outside air at this voxel size";
      continue;
    }
    for (double& x : c) x /= static_cast<double>(count);
    l.found = true;
    l.position_mm = g.physical(c[0], c[1], c[2]);
    l.confidence = (count >= 3 ? 0.7 : 0.4) * (out.frame.orientation_recorded ? 1.0 : 0.7);
    l.reason =
        std::to_string(count) + " voxels where the nasal cavity meets the outside air, " +
        (side == 0 ? "left" : "right") + " of the midline" +
        (out.frame.orientation_recorded ? "" : " (left/right not recorded: +x taken as left)");
  }

  // ---- paranasal air spaces: by position relative to the midline and the nasal cavity --------
  if (nasal.found) {
    double nc_sup_lo = std::numeric_limits<double>::max(), nc_sup_hi = -nc_sup_lo;
    double nc_ant_hi = -std::numeric_limits<double>::max(), nc_ant_sum = 0, nc_sup_sum = 0;
    std::size_t nc_count = 0;
    for (int k = 0; k < g.n[2]; ++k)
      for (int j = 0; j < g.n[1]; ++j)
        for (int i = 0; i < g.n[0]; ++i) {
          if (!in_nasal[g.index(i, j, k)]) continue;
          const int idx[3] = {i, j, k};
          nc_sup_lo = std::min(nc_sup_lo, g.sup(idx));
          nc_sup_hi = std::max(nc_sup_hi, g.sup(idx));
          nc_ant_hi = std::max(nc_ant_hi, g.ant(idx));
          nc_ant_sum += g.ant(idx);
          nc_sup_sum += g.sup(idx);
          ++nc_count;
        }
    const double nc_ant_c = nc_ant_sum / static_cast<double>(nc_count);
    const double nc_sup_c = nc_sup_sum / static_cast<double>(nc_count);
    std::array<Accumulator, 5> acc;  // maxillary-left, maxillary-right, frontal, sphenoid, ethmoid
    std::size_t connected[5] = {0, 0, 0, 0, 0};
    const int step[3] = {1, g.n[0], g.n[0] * g.n[1]};
    for (int k = 0; k < g.n[2]; ++k)
      for (int j = 0; j < g.n[1]; ++j)
        for (int i = 0; i < g.n[0]; ++i) {
          const std::size_t v = g.index(i, j, k);
          if (!air[v] || in_nasal[v]) continue;
          const int idx[3] = {i, j, k};
          const double lat = g.lat(idx), a = g.ant(idx), z = g.sup(idx);
          int cls = -1;
          if (z > nc_sup_hi + 10.0 && z <= nc_sup_hi + 70.0 && a > nc_ant_hi - 45.0 &&
              std::abs(lat) <= 35.0)
            cls = 2;
          else if (std::abs(lat) <= 20.0 && a < nc_ant_c - 15.0 && a >= nc_ant_hi - 90.0 &&
                   z > nc_sup_c && z <= nc_sup_hi + 30.0)
            cls = 3;
          else if (std::abs(lat) <= 25.0 && z > nc_sup_c && z <= nc_sup_hi + 25.0 &&
                   a >= nc_ant_hi - 70.0)
            cls = 4;
          else if (std::abs(lat) > 12.0 && std::abs(lat) <= 50.0 && z <= nc_sup_c + 15.0 &&
                   a >= nc_ant_c - 25.0)
            cls = lat > 0 ? 0 : 1;
          if (cls < 0) continue;
          acc[cls].add(g.physical(i, j, k));
          bool touches = false;
          for (int ax = 0; ax < 3 && !touches; ++ax)
            for (int d = -1; d <= 1 && !touches; d += 2) {
              if (idx[ax] + d < 0 || idx[ax] + d >= g.n[ax]) continue;
              touches = in_nasal[v + static_cast<std::ptrdiff_t>(d) * step[ax]] != 0;
            }
          connected[cls] += touches ? 1 : 0;
        }
    const char* rules[5] = {
        "air spaces left of and lateral to the nasal cavity (|x - mid| > 12 mm), below its "
        "centre + 15 mm",
        "air spaces right of and lateral to the nasal cavity (|x - mid| > 12 mm), below its "
        "centre + 15 mm",
        "air spaces 10-70 mm above the nasal cavity's top, within 45 mm of its front",
        "midline air spaces behind the nasal cavity's centre (15-90 mm) and above it",
        "midline air spaces above the nasal cavity's centre, neither frontal nor sphenoid"};
    for (int c = 0; c < 5; ++c) {
      AnatomyRegion& r = out.regions[1 + c];
      acc[c].fill(r, voxel_ml);
      if (r.ml < kMinParanasalMl) {
        r.found = false;
        r.confidence = 0.1;
        r.reason = std::string("not separated: ") + fmt(r.ml, 2) + " ml where the rule looks (" +
                   rules[c] + ")";
        continue;
      }
      r.found = true;
      r.confidence = connected[c] > 0 ? 0.35 : 0.5;
      if (c <= 1 && !out.frame.orientation_recorded) r.confidence *= 0.7;
      r.reason = std::string("geometric rule, not walls: ") + rules[c] +
                 (connected[c] > 0 ? "; joined to the nasal cavity at this voxel size" : "");
    }
  } else {
    for (int c = 1; c < 6; ++c)
      out.regions[static_cast<std::size_t>(c)].reason =
          "not found: placed relative to the nasal cavity, which was not found";
  }

  if (!out.frame.orientation_recorded)
    out.warnings.push_back(
        "anatomy: left/right is unknown (the CT records no patient orientation): +x is taken as "
        "left; nostril-left/right and maxillary-left/right may be swapped");
  return out;
}

namespace {

nlohmann::json v3(const Vec3d& v) {
  return nlohmann::json::array({v.x, v.y, v.z});
}

}  // namespace

nlohmann::json sinus_anatomy_json(const SinusAnatomy& a) {
  using nlohmann::json;
  json regions = json::array(), landmarks = json::array();
  for (const AnatomyRegion& r : a.regions) {
    json j{
        {"name", r.name}, {"found", r.found}, {"confidence", r.confidence}, {"reason", r.reason}};
    if (r.found) {
      j["bbox_mm"] = {{"min", v3(r.min_mm)}, {"max", v3(r.max_mm)}};
      j["centroid_mm"] = v3(r.centroid_mm);
      j["ml"] = r.ml;
    }
    regions.push_back(j);
  }
  for (const AnatomyLandmark& l : a.landmarks) {
    json j{
        {"name", l.name}, {"found", l.found}, {"confidence", l.confidence}, {"reason", l.reason}};
    if (l.found) j["position_mm"] = v3(l.position_mm);
    landmarks.push_back(j);
  }
  const AnatomyPlane& m = a.midsagittal;
  json plane{
      {"name", m.name}, {"found", m.found}, {"confidence", m.confidence}, {"reason", m.reason}};
  if (m.found) {
    plane["point_mm"] = v3(m.point_mm);
    plane["normal"] = v3(m.normal);
  }
  return {{"frame", "patient (LPS), mm"},
          {"directions",
           {{"left", v3(a.frame.left)},
            {"anterior", v3(a.frame.anterior)},
            {"superior", v3(a.frame.superior)}}},
          {"orientation_recorded", a.frame.orientation_recorded},
          {"facing",
           {{"anterior", v3(a.frame.anterior)},
            {"agrees_with_frame", a.frame.facing_agrees},
            {"confidence", a.frame.facing_confidence},
            {"reason", a.frame.facing_reason}}},
          {"planes", json::array({plane})},
          {"regions", regions},
          {"landmarks", landmarks},
          {"warnings", a.warnings}};
}

}  // namespace tsf::segment
