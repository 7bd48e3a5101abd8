#include "tsf/segment/slice_preview.h"

#include <itkImageFileWriter.h>
#include <itkPNGImageIO.h>
#include <itkRGBPixel.h>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <string>
#include <vector>

#include "bitmap_font_5x7.h"
#include "tsf/common/atomic_file.h"
#include "tsf/common/error.h"
#include "tsf/volume/tissue_labels.h"

namespace tsf::segment {

namespace {

using Rgb = std::array<unsigned char, 3>;

constexpr Rgb kAirSpaceColour{40, 140, 255};
constexpr Rgb kBackground{24, 24, 28};
constexpr Rgb kText{235, 235, 235};

/// An RGB raster with the few drawing operations the preview needs.
class Canvas {
 public:
  Canvas(int width, int height) : width_(width), height_(height), rgb_(3u * width * height) {
    fill_rect(0, 0, width, height, kBackground);
  }
  int width() const { return width_; }
  int height() const { return height_; }
  const std::vector<unsigned char>& pixels() const { return rgb_; }

  void set(int x, int y, const Rgb& c) {
    if (x < 0 || y < 0 || x >= width_ || y >= height_) return;
    unsigned char* p = &rgb_[3u * (static_cast<std::size_t>(y) * width_ + x)];
    p[0] = c[0];
    p[1] = c[1];
    p[2] = c[2];
  }
  void fill_rect(int x, int y, int w, int h, const Rgb& c) {
    for (int yy = y; yy < y + h; ++yy)
      for (int xx = x; xx < x + w; ++xx) set(xx, yy, c);
  }
  /// Draws `text` with its top-left corner at (x, y); glyph pixels are `scale` px squares.
  int text(int x, int y, const std::string& text, int scale, const Rgb& c) {
    for (char ch : text) {
      const auto rows = glyph_5x7(ch);
      for (int r = 0; r < 7; ++r)
        for (int b = 0; b < 5; ++b)
          if (rows[r] & (0x10 >> b)) fill_rect(x + b * scale, y + r * scale, scale, scale, c);
      x += 6 * scale;
    }
    return x;
  }

 private:
  int width_, height_;
  std::vector<unsigned char> rgb_;
};

Rgb mix(const Rgb& a, const Rgb& b, float t) {
  Rgb out;
  for (int c = 0; c < 3; ++c)
    out[c] = static_cast<unsigned char>(std::lround((1.0f - t) * a[c] + t * b[c]));
  return out;
}

/// One view: panel pixel (u, v) -> voxel index.
struct View {
  std::string title;
  int width, height;  // in voxels
  std::array<int, 3> (*to_index)(int u, int v, const std::array<int, 3>& dims,
                                 const std::array<int, 3>& slice);
};

std::array<int, 3> centroid_of(const unsigned char* mask, const std::array<int, 3>& dims,
                               bool& found, bool (*test)(unsigned char)) {
  double sum[3] = {0, 0, 0};
  std::size_t count = 0, v = 0;
  for (int k = 0; k < dims[2]; ++k)
    for (int j = 0; j < dims[1]; ++j)
      for (int i = 0; i < dims[0]; ++i, ++v)
        if (test(mask[v])) {
          sum[0] += i;
          sum[1] += j;
          sum[2] += k;
          ++count;
        }
  found = count > 0;
  if (!found) return {dims[0] / 2, dims[1] / 2, dims[2] / 2};
  return {static_cast<int>(sum[0] / count), static_cast<int>(sum[1] / count),
          static_cast<int>(sum[2] / count)};
}

std::string format_ml(double ml) {
  char buffer[32];
  std::snprintf(buffer, sizeof buffer, ml >= 100.0 ? "%.0f ML" : "%.1f ML", ml);
  return buffer;
}

constexpr Rgb kMarker{255, 230, 0};
constexpr Rgb kLetter{120, 255, 120};

/// The patient direction letter of index axis `axis` going `sign` (+1/−1), from the anatomy's
/// directions; blank for left/right when the CT records no orientation.
char direction_letter(const SinusAnatomy& a, const HuImage* hu, int axis, int sign) {
  Vec3d col{hu->GetDirection()[0][axis], hu->GetDirection()[1][axis], hu->GetDirection()[2][axis]};
  col = col * static_cast<double>(sign);
  const double l = dot(col, a.frame.left), an = dot(col, a.frame.anterior),
               s = dot(col, a.frame.superior);
  if (std::abs(l) >= std::abs(an) && std::abs(l) >= std::abs(s))
    return a.frame.orientation_recorded ? (l > 0 ? 'L' : 'R') : ' ';
  if (std::abs(an) >= std::abs(s)) return an > 0 ? 'A' : 'P';
  return s > 0 ? 'S' : 'I';
}

/// Continuous index of an LPS point on the preview's grid.
std::array<double, 3> point_index(const HuImage* hu, const Vec3d& p) {
  std::array<double, 3> out{};
  const auto& o = hu->GetOrigin();
  const auto& d = hu->GetDirection();
  const double sp = hu->GetSpacing()[0];
  for (int c = 0; c < 3; ++c)
    out[c] = (d[0][c] * (p.x - o[0]) + d[1][c] * (p.y - o[1]) + d[2][c] * (p.z - o[2])) / sp;
  return out;
}

/// Panel coordinates (u, v) of a continuous index, per view (0 axial, 1 coronal, 2 sagittal).
std::array<double, 2> panel_uv(int view, const std::array<double, 3>& idx,
                               const std::array<int, 3>& dims) {
  if (view == 0) return {idx[0], idx[1]};
  if (view == 1) return {idx[0], dims[2] - 1 - idx[2]};
  return {idx[1], dims[2] - 1 - idx[2]};
}

/// Orientation letters at the panel's edges, the nasal cavity's box and the landmarks' crosses.
template <typename ViewT>
void draw_anatomy(Canvas& canvas, const SinusAnatomy& a, const HuImage* hu, const ViewT& view,
                  const std::vector<ViewT>& views, const std::array<int, 3>& dims, int left,
                  int top, int scale) {
  const int which = static_cast<int>(&view - views.data());
  // The index axes along u (right) and v (down) of this panel.
  const int u_axis = which == 2 ? 1 : 0;
  const int v_axis = which == 0 ? 1 : 2;
  const int v_sign = which == 0 ? 1 : -1;
  const int w = view.width * scale, h = view.height * scale;
  constexpr int kS = 2;
  auto letter = [&](int x, int y, char c) { canvas.text(x, y, std::string(1, c), kS, kLetter); };
  letter(left + w - 6 * kS - 2, top + h / 2 - 7, direction_letter(a, hu, u_axis, 1));
  letter(left + 2, top + h / 2 - 7, direction_letter(a, hu, u_axis, -1));
  letter(left + w / 2 - 5, top + 2, direction_letter(a, hu, v_axis, -v_sign));
  letter(left + w / 2 - 5, top + h - 7 * kS - 2, direction_letter(a, hu, v_axis, v_sign));
  if (!a.frame.orientation_recorded) canvas.text(left + 2, top + 2, "L/R UNKNOWN", 1, kLetter);
  auto in_panel = [&](int x, int y) {
    return x >= left && x < left + w && y >= top && y < top + h;
  };
  auto mark = [&](int x, int y) {
    if (in_panel(x, y)) canvas.set(x, y, kMarker);
  };
  if (const AnatomyRegion* nc = a.region("nasal-cavity"); nc && nc->found) {
    const auto lo = panel_uv(which, point_index(hu, nc->min_mm), dims);
    const auto hi = panel_uv(which, point_index(hu, nc->max_mm), dims);
    const int x0 = left + static_cast<int>(std::lround(std::min(lo[0], hi[0]) * scale));
    const int x1 = left + static_cast<int>(std::lround((std::max(lo[0], hi[0]) + 1) * scale));
    const int y0 = top + static_cast<int>(std::lround(std::min(lo[1], hi[1]) * scale));
    const int y1 = top + static_cast<int>(std::lround((std::max(lo[1], hi[1]) + 1) * scale));
    for (int x = x0; x <= x1; ++x) {
      mark(x, y0);
      mark(x, y1);
    }
    for (int y = y0; y <= y1; ++y) {
      mark(x0, y);
      mark(x1, y);
    }
  }
  for (const AnatomyLandmark& l : a.landmarks) {
    if (!l.found) continue;
    const auto uv = panel_uv(which, point_index(hu, l.position_mm), dims);
    const int x = left + static_cast<int>(std::lround((uv[0] + 0.5) * scale));
    const int y = top + static_cast<int>(std::lround((uv[1] + 0.5) * scale));
    for (int d = -5; d <= 5; ++d) {
      mark(x + d, y);
      mark(x, y + d);
    }
  }
}

}  // namespace

Rgb label_preview_colour(unsigned char label) {
  switch (label) {
    case kLabelSoftTissue:
      return {230, 110, 90};
    case kLabelMucosa:
      return {240, 60, 220};
    case kLabelFat:
      return {250, 220, 40};
    case kLabelCartilage:
      return {60, 220, 200};
    case kLabelCancellousBone:
      return {250, 150, 30};
    case kLabelCorticalBone:
      return {245, 245, 215};
    case kLabelTumour:
      return {150, 60, 255};
    case kLabelVessel:
      return {255, 20, 20};
    case kLabelNerve:
      return {255, 255, 0};
    default: {
      // Other labels: a stable colour from the label value.
      const unsigned h = label * 2654435761u;
      return {static_cast<unsigned char>(80 + (h >> 8) % 176),
              static_cast<unsigned char>(80 + (h >> 16) % 176),
              static_cast<unsigned char>(80 + (h >> 24) % 176)};
    }
  }
}

SlicePreviewInfo write_slice_preview(const std::filesystem::path& png,
                                     const SegmentationImages& images,
                                     const SegmentationStatistics& stats,
                                     const SlicePreviewOptions& options) {
  require(images.hu && images.labels, "slice preview: the segmentation has no HU or label image");
  const auto size = images.hu->GetLargestPossibleRegion().GetSize();
  const std::array<int, 3> dims{static_cast<int>(size[0]), static_cast<int>(size[1]),
                                static_cast<int>(size[2])};
  const float* hu = images.hu->GetBufferPointer();
  const unsigned char* labels = images.labels->GetBufferPointer();
  const unsigned char* air = images.air_spaces ? images.air_spaces->GetBufferPointer() : nullptr;

  bool found = false;
  std::array<int, 3> slice{};
  if (air) slice = centroid_of(air, dims, found, [](unsigned char a) { return a != 0; });
  if (!found)
    slice = centroid_of(labels, dims, found, [](unsigned char l) { return l != kLabelOutside; });

  const std::vector<View> views = {
      {"AXIAL K=" + std::to_string(slice[2]), dims[0], dims[1],
       [](int u, int v, const std::array<int, 3>&, const std::array<int, 3>& s) {
         return std::array<int, 3>{u, v, s[2]};
       }},
      {"CORONAL J=" + std::to_string(slice[1]), dims[0], dims[2],
       [](int u, int v, const std::array<int, 3>& d, const std::array<int, 3>& s) {
         return std::array<int, 3>{u, s[1], d[2] - 1 - v};
       }},
      {"SAGITTAL I=" + std::to_string(slice[0]), dims[1], dims[2],
       [](int u, int v, const std::array<int, 3>& d, const std::array<int, 3>& s) {
         return std::array<int, 3>{s[0], u, d[2] - 1 - v};
       }},
  };

  int scale = options.scale;
  if (scale <= 0) {
    const int longest = std::max({dims[0], dims[1], dims[2]});
    scale = std::max(1, (320 + longest - 1) / longest);
  }
  constexpr int kMargin = 10, kTitle = 2, kTitleHeight = 7 * kTitle + 8;
  int width = kMargin, panels_height = 0;
  for (const auto& v : views) {
    width += v.width * scale + kMargin;
    panels_height = std::max(panels_height, v.height * scale);
  }

  // Legend entries: every class present, then the air spaces.
  struct Entry {
    Rgb colour;
    std::string text;
  };
  std::vector<Entry> legend;
  for (const auto& c : stats.classes)
    legend.push_back({label_preview_colour(c.label), c.name + " " + format_ml(c.region.ml)});
  if (stats.air_spaces.voxels > 0)
    legend.push_back({kAirSpaceColour, "air spaces " + format_ml(stats.air_spaces.ml)});
  constexpr int kLegendText = 2, kRow = 7 * kLegendText + 8;
  // Lay the legend out in rows that fit the width.
  std::vector<std::pair<int, int>> positions;
  int x = kMargin, rows = legend.empty() ? 0 : 1;
  for (const auto& e : legend) {
    const int w = kRow + 6 * kLegendText * static_cast<int>(e.text.size()) + 16;
    if (x + w > width && x > kMargin) {
      x = kMargin;
      ++rows;
    }
    positions.emplace_back(x, rows - 1);
    x += w;
  }
  const int legend_top = kMargin + kTitleHeight + panels_height + kMargin;
  const int height = legend_top + rows * kRow + kMargin;

  Canvas canvas(width, height);
  const float lo = static_cast<float>(options.window_min_hu);
  const float span = static_cast<float>(options.window_max_hu - options.window_min_hu);
  int left = kMargin;
  for (const auto& view : views) {
    canvas.text(left, kMargin, view.title, kTitle, kText);
    const int top = kMargin + kTitleHeight;
    for (int v = 0; v < view.height; ++v)
      for (int u = 0; u < view.width; ++u) {
        const auto idx = view.to_index(u, v, dims, slice);
        const std::size_t voxel =
            static_cast<std::size_t>(idx[0]) +
            static_cast<std::size_t>(dims[0]) *
                (static_cast<std::size_t>(idx[1]) + static_cast<std::size_t>(dims[1]) * idx[2]);
        const float g = std::clamp((hu[voxel] - lo) / span, 0.0f, 1.0f);
        const auto grey = static_cast<unsigned char>(std::lround(255.0f * g));
        Rgb c{grey, grey, grey};
        if (labels[voxel] != kLabelOutside)
          c = mix(c, label_preview_colour(labels[voxel]), options.tint);
        else if (air && air[voxel])
          c = mix(c, kAirSpaceColour, std::min(1.0f, options.tint + 0.2f));
        canvas.fill_rect(left + u * scale, top + v * scale, scale, scale, c);
      }
    if (options.anatomy)
      draw_anatomy(canvas, *options.anatomy, images.hu, view, views, dims, left, top, scale);
    left += view.width * scale + kMargin;
  }
  for (std::size_t e = 0; e < legend.size(); ++e) {
    const int ex = positions[e].first, ey = legend_top + positions[e].second * kRow;
    canvas.fill_rect(ex, ey, kRow - 8, kRow - 8, legend[e].colour);
    canvas.text(ex + kRow, ey + 1, legend[e].text, kLegendText, kText);
  }

  using RgbImage = itk::Image<itk::RGBPixel<unsigned char>, 2>;
  auto image = RgbImage::New();
  RgbImage::SizeType png_size;
  png_size[0] = static_cast<itk::SizeValueType>(width);
  png_size[1] = static_cast<itk::SizeValueType>(height);
  image->SetRegions(RgbImage::RegionType(png_size));
  image->Allocate();
  std::copy(canvas.pixels().begin(), canvas.pixels().end(),
            reinterpret_cast<unsigned char*>(image->GetBufferPointer()));
  write_file_atomically(png, [&](const std::filesystem::path& temp) {
    auto writer = itk::ImageFileWriter<RgbImage>::New();
    writer->SetImageIO(itk::PNGImageIO::New());
    writer->SetFileName(temp.string());
    writer->SetInput(image);
    writer->SetUseCompression(true);
    try {
      writer->Update();
    } catch (const itk::ExceptionObject& e) {
      throw Error("cannot write preview '" + png.string() + "': " + e.GetDescription());
    }
  });
  return {slice, width, height};
}

}  // namespace tsf::segment
