// Renders an exported mesh file (read back through assimp's importer, as any consumer would) to a
// PNG with a small software rasteriser, so docs/export.md can show what `tsf export` wrote.
//
//   render_glb_preview IN.{glb,gltf,obj,fbx,ply,stl} OUT.png [--size W H] [--yaw DEG]
//
// Two panels: the exterior seen from yaw DEG about +Y (default 35: front-left when +Z is
// anterior, as in y-up files) and 15° above, and a sagittal cut-away (triangles with x above the
// bounding-box centre dropped) seen from +X (the patient's left), which shows the air spaces
// inside. Vertex colours are shown as stored (glTF COLOR_0 is linear and is converted to sRGB
// for display); Lambert shading with a head light, both sides lit; 2×2 supersampling.
#include <assimp/scene.h>
#include <zlib.h>
#include <assimp/Importer.hpp>

#include <algorithm>
#include <array>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <fstream>
#include <string>
#include <vector>

namespace {

struct V3 {
  double x = 0, y = 0, z = 0;
};
V3 operator-(V3 a, V3 b) {
  return {a.x - b.x, a.y - b.y, a.z - b.z};
}
V3 operator+(V3 a, V3 b) {
  return {a.x + b.x, a.y + b.y, a.z + b.z};
}
V3 operator*(V3 a, double s) {
  return {a.x * s, a.y * s, a.z * s};
}
double dot(V3 a, V3 b) {
  return a.x * b.x + a.y * b.y + a.z * b.z;
}
V3 normalise(V3 a) {
  const double l = std::sqrt(dot(a, a));
  return l > 0 ? a * (1.0 / l) : V3{0, 0, 1};
}

struct Vertex {
  V3 p, n, colour;  ///< colour: display sRGB in [0,1]
};
struct Mesh {
  std::vector<Vertex> vertices;
  std::vector<std::array<std::size_t, 3>> triangles;
};

double linear_to_srgb(double c) {
  c = std::clamp(c, 0.0, 1.0);
  return c <= 0.0031308 ? 12.92 * c : 1.055 * std::pow(c, 1.0 / 2.4) - 0.055;
}

void collect(const aiScene* s, const aiNode* node, aiMatrix4x4 parent, bool linear, Mesh& out) {
  const aiMatrix4x4 m = parent * node->mTransformation;
  aiMatrix3x3 normal_matrix(m);
  normal_matrix.Inverse().Transpose();
  for (unsigned i = 0; i < node->mNumMeshes; ++i) {
    const aiMesh* am = s->mMeshes[node->mMeshes[i]];
    const std::size_t base = out.vertices.size();
    for (unsigned v = 0; v < am->mNumVertices; ++v) {
      const aiVector3D p = m * am->mVertices[v];
      Vertex x;
      x.p = {p.x, p.y, p.z};
      if (am->HasNormals()) {
        const aiVector3D n = normal_matrix * am->mNormals[v];
        x.n = normalise({n.x, n.y, n.z});
      }
      x.colour = {0.8, 0.8, 0.8};
      if (am->HasVertexColors(0)) {
        const aiColor4D c = am->mColors[0][v];
        x.colour = linear ? V3{linear_to_srgb(c.r), linear_to_srgb(c.g), linear_to_srgb(c.b)}
                          : V3{c.r, c.g, c.b};
      }
      out.vertices.push_back(x);
    }
    for (unsigned f = 0; f < am->mNumFaces; ++f)
      if (am->mFaces[f].mNumIndices == 3)
        out.triangles.push_back({base + am->mFaces[f].mIndices[0], base + am->mFaces[f].mIndices[1],
                                 base + am->mFaces[f].mIndices[2]});
  }
  for (unsigned c = 0; c < node->mNumChildren; ++c) collect(s, node->mChildren[c], m, linear, out);
}

struct Image {
  int w, h;
  std::vector<V3> rgb;
  std::vector<double> depth;
  Image(int width, int height)
      : w(width),
        h(height),
        rgb(static_cast<std::size_t>(width) * height, V3{1, 1, 1}),
        depth(static_cast<std::size_t>(width) * height, -1e300) {}
};

/// Draws `mesh` orthographically into the panel [x0, x0 + pw) of `img`.
void render(const Mesh& mesh, double yaw_deg, double pitch_deg, bool cut, Image& img, int x0,
            int pw) {
  V3 lo{1e300, 1e300, 1e300}, hi{-1e300, -1e300, -1e300};
  for (const Vertex& v : mesh.vertices) {
    lo = {std::min(lo.x, v.p.x), std::min(lo.y, v.p.y), std::min(lo.z, v.p.z)};
    hi = {std::max(hi.x, v.p.x), std::max(hi.y, v.p.y), std::max(hi.z, v.p.z)};
  }
  const V3 centre = (lo + hi) * 0.5;
  const double yaw = yaw_deg * M_PI / 180, pitch = pitch_deg * M_PI / 180;
  // Camera axes: right, up, towards the viewer (view = rotate the model by yaw about Y, then
  // pitch about X).
  const V3 right{std::cos(yaw), 0, -std::sin(yaw)};
  const V3 toward{std::sin(yaw) * std::cos(pitch), std::sin(pitch),
                  std::cos(yaw) * std::cos(pitch)};
  const V3 up{-std::sin(yaw) * std::sin(pitch), std::cos(pitch), -std::cos(yaw) * std::sin(pitch)};
  // Fit the projected bounding box of the (kept) vertices to 94% of the panel.
  double u0 = 1e300, u1 = -1e300, v0 = 1e300, v1 = -1e300;
  for (const Vertex& v : mesh.vertices) {
    if (cut && v.p.x > centre.x) continue;
    const V3 q = v.p - centre;
    u0 = std::min(u0, dot(q, right));
    u1 = std::max(u1, dot(q, right));
    v0 = std::min(v0, dot(q, up));
    v1 = std::max(v1, dot(q, up));
  }
  const double scale = 0.94 * std::min(pw / (u1 - u0), img.h / (v1 - v0));
  const double mid_u = 0.5 * (u0 + u1), mid_v = 0.5 * (v0 + v1);
  const V3 light = normalise(toward + up * 0.4 + right * -0.3);
  std::vector<V3> screen(mesh.vertices.size()), lit(mesh.vertices.size());
  for (std::size_t i = 0; i < mesh.vertices.size(); ++i) {
    const V3 q = mesh.vertices[i].p - centre;
    screen[i] = {x0 + pw * 0.5 + (dot(q, right) - mid_u) * scale,
                 img.h * 0.5 - (dot(q, up) - mid_v) * scale, dot(q, toward)};
    const double diffuse = std::fabs(dot(mesh.vertices[i].n, light));
    lit[i] = mesh.vertices[i].colour * (0.25 + 0.75 * diffuse);
  }
  for (const auto& t : mesh.triangles) {
    if (cut) {
      const double cx =
          (mesh.vertices[t[0]].p.x + mesh.vertices[t[1]].p.x + mesh.vertices[t[2]].p.x) / 3;
      if (cx > centre.x) continue;
    }
    const V3 &a = screen[t[0]], &b = screen[t[1]], &c = screen[t[2]];
    const double area = (b.x - a.x) * (c.y - a.y) - (b.y - a.y) * (c.x - a.x);
    if (std::fabs(area) < 1e-12) continue;
    const int xmin = std::max(x0, static_cast<int>(std::floor(std::min({a.x, b.x, c.x}))));
    const int xmax = std::min(x0 + pw - 1, static_cast<int>(std::ceil(std::max({a.x, b.x, c.x}))));
    const int ymin = std::max(0, static_cast<int>(std::floor(std::min({a.y, b.y, c.y}))));
    const int ymax = std::min(img.h - 1, static_cast<int>(std::ceil(std::max({a.y, b.y, c.y}))));
    for (int y = ymin; y <= ymax; ++y)
      for (int x = xmin; x <= xmax; ++x) {
        const double px = x + 0.5, py = y + 0.5;
        const double w0 = ((b.x - px) * (c.y - py) - (b.y - py) * (c.x - px)) / area;
        const double w1 = ((c.x - px) * (a.y - py) - (c.y - py) * (a.x - px)) / area;
        const double w2 = 1 - w0 - w1;
        if (w0 < 0 || w1 < 0 || w2 < 0) continue;
        const double z = w0 * a.z + w1 * b.z + w2 * c.z;
        const std::size_t k = static_cast<std::size_t>(y) * img.w + x;
        if (z <= img.depth[k]) continue;
        img.depth[k] = z;
        img.rgb[k] = lit[t[0]] * w0 + lit[t[1]] * w1 + lit[t[2]] * w2;
      }
  }
}

void put_u32(std::string& s, std::uint32_t v) {
  for (int i = 3; i >= 0; --i) s.push_back(static_cast<char>((v >> (8 * i)) & 0xff));
}

void chunk(std::string& png, const char* type, const std::string& data) {
  put_u32(png, static_cast<std::uint32_t>(data.size()));
  std::string body = std::string(type, 4) + data;
  png += body;
  put_u32(png, static_cast<std::uint32_t>(crc32(0, reinterpret_cast<const Bytef*>(body.data()),
                                                static_cast<uInt>(body.size()))));
}

/// 8-bit RGB PNG; each row gets the filter (of the five) with the smallest sum of magnitudes.
bool write_png(const char* path, int w, int h, const std::vector<std::uint8_t>& rgb) {
  const std::size_t stride = static_cast<std::size_t>(w) * 3;
  std::string raw;
  std::vector<std::uint8_t> zero(stride, 0), best, row(stride);
  for (int y = 0; y < h; ++y) {
    const std::uint8_t* cur = &rgb[y * stride];
    const std::uint8_t* prev = y ? &rgb[(y - 1) * stride] : zero.data();
    long best_cost = -1;
    int best_filter = 0;
    for (int f = 0; f < 5; ++f) {
      long cost = 0;
      for (std::size_t i = 0; i < stride; ++i) {
        const int a = i >= 3 ? cur[i - 3] : 0, b = prev[i], c = i >= 3 ? prev[i - 3] : 0;
        int pred = 0;
        if (f == 1) pred = a;
        if (f == 2) pred = b;
        if (f == 3) pred = (a + b) / 2;
        if (f == 4) {
          const int p = a + b - c, pa = std::abs(p - a), pb = std::abs(p - b), pc = std::abs(p - c);
          pred = (pa <= pb && pa <= pc) ? a : (pb <= pc ? b : c);
        }
        row[i] = static_cast<std::uint8_t>(cur[i] - pred);
        cost += std::abs(static_cast<std::int8_t>(row[i]));
      }
      if (best_cost < 0 || cost < best_cost) {
        best_cost = cost;
        best_filter = f;
        best = row;
      }
    }
    raw.push_back(static_cast<char>(best_filter));
    raw.append(reinterpret_cast<const char*>(best.data()), stride);
  }
  uLongf packed_size = compressBound(static_cast<uLong>(raw.size()));
  std::string packed(packed_size, '\0');
  if (compress2(reinterpret_cast<Bytef*>(&packed[0]), &packed_size,
                reinterpret_cast<const Bytef*>(raw.data()), static_cast<uLong>(raw.size()),
                9) != Z_OK)
    return false;
  packed.resize(packed_size);
  std::string png("\x89PNG\r\n\x1a\n", 8), ihdr;
  put_u32(ihdr, static_cast<std::uint32_t>(w));
  put_u32(ihdr, static_cast<std::uint32_t>(h));
  ihdr += std::string("\x08\x02\x00\x00\x00", 5);  // 8-bit, RGB, deflate, no interlace
  chunk(png, "IHDR", ihdr);
  chunk(png, "IDAT", packed);
  chunk(png, "IEND", "");
  std::ofstream out(path, std::ios::binary);
  out.write(png.data(), static_cast<std::streamsize>(png.size()));
  return static_cast<bool>(out);
}

}  // namespace

int main(int argc, char** argv) {
  if (argc < 3) {
    std::fprintf(stderr, "usage: render_glb_preview IN OUT.png [--size W H] [--yaw DEG]\n");
    return 2;
  }
  int width = 1200, height = 600;
  double yaw = 35.0;
  for (int a = 3; a < argc; ++a) {
    if (!std::strcmp(argv[a], "--size") && a + 2 < argc) {
      width = std::atoi(argv[++a]);
      height = std::atoi(argv[++a]);
    } else if (!std::strcmp(argv[a], "--yaw") && a + 1 < argc) {
      yaw = std::atof(argv[++a]);
    } else {
      std::fprintf(stderr, "render_glb_preview: unknown argument '%s'\n", argv[a]);
      return 2;
    }
  }
  Assimp::Importer importer;
  const aiScene* scene = importer.ReadFile(argv[1], 0);
  if (!scene) {
    std::fprintf(stderr, "render_glb_preview: cannot read %s: %s\n", argv[1],
                 importer.GetErrorString());
    return 1;
  }
  const std::string in = argv[1];
  const bool linear =
      in.size() > 4 && (in.substr(in.size() - 4) == ".glb" || in.substr(in.size() - 5) == ".gltf");
  Mesh mesh;
  collect(scene, scene->mRootNode, aiMatrix4x4(), linear, mesh);
  if (mesh.triangles.empty()) {
    std::fprintf(stderr, "render_glb_preview: %s has no triangles\n", argv[1]);
    return 1;
  }
  const int ss = 2;  // supersampling
  Image img(width * ss, height * ss);
  render(mesh, yaw, 15, false, img, 0, img.w / 2);
  render(mesh, 90, 0, true, img, img.w / 2, img.w / 2);
  std::vector<std::uint8_t> rgb(static_cast<std::size_t>(width) * height * 3);
  for (int y = 0; y < height; ++y)
    for (int x = 0; x < width; ++x) {
      V3 sum{0, 0, 0};
      for (int dy = 0; dy < ss; ++dy)
        for (int dx = 0; dx < ss; ++dx)
          sum = sum + img.rgb[static_cast<std::size_t>(y * ss + dy) * img.w + (x * ss + dx)];
      sum = sum * (1.0 / (ss * ss));
      const std::size_t k = (static_cast<std::size_t>(y) * width + x) * 3;
      rgb[k] = static_cast<std::uint8_t>(std::lround(std::clamp(sum.x, 0.0, 1.0) * 255));
      rgb[k + 1] = static_cast<std::uint8_t>(std::lround(std::clamp(sum.y, 0.0, 1.0) * 255));
      rgb[k + 2] = static_cast<std::uint8_t>(std::lround(std::clamp(sum.z, 0.0, 1.0) * 255));
    }
  if (!write_png(argv[2], width, height, rgb)) {
    std::fprintf(stderr, "render_glb_preview: cannot write %s\n", argv[2]);
    return 1;
  }
  std::printf("render_glb_preview: %zu triangles from %s -> %s (%dx%d)\n", mesh.triangles.size(),
              argv[1], argv[2], width, height);
  return 0;
}
