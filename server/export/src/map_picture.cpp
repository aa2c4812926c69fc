// Top-down picture of the octree with the robots' trajectories.
#include "rgbdmap/export/map_picture.hpp"

#include <algorithm>
#include <cmath>
#include <iomanip>
#include <map>
#include <sstream>
#include <unordered_set>

#include <opencv2/imgcodecs.hpp>
#include <opencv2/imgproc.hpp>

#include "atomic_file.hpp"

namespace rgbdmap {
namespace {

constexpr int kMaxSidePx = 10000;

struct Leaf {
  Vec3 p;
  double size;
  double height;
};

struct Leaves {
  std::vector<Leaf> occupied, free;
};

cv::Scalar bgr(const std::array<uint8_t, 3>& rgb) { return cv::Scalar(rgb[2], rgb[1], rgb[0]); }

Leaves collectLeaves(const octomap::OcTree& tree, const Vec3& up) {
  Leaves leaves;
  for (auto it = tree.begin_leafs(), end = tree.end_leafs(); it != end; ++it) {
    const octomap::point3d c = it.getCoordinate();
    Leaf leaf{Vec3(c.x(), c.y(), c.z()), it.getSize(), 0.0};
    leaf.height = leaf.p.dot(up);
    (tree.isNodeOccupied(*it) ? leaves.occupied : leaves.free).push_back(leaf);
  }
  return leaves;
}

/// Height above which a ceiling starts: the lowest of the top height bins (one resolution thick) that each
/// cover at least `min_cover` of the occupied footprint (distinct columns). +inf when there is none.
double ceilingCut(const std::vector<Leaf>& occupied, const MapPictureLayout& layout, double resolution,
                  double min_cover) {
  if (occupied.empty() || min_cover <= 0.0) return std::numeric_limits<double>::infinity();
  std::map<long, double> bin_cover;  // height bin -> covered area (m^2)
  std::unordered_set<uint64_t> columns;
  for (const Leaf& l : occupied) {
    bin_cover[std::lround(std::floor(l.height / resolution))] += l.size * l.size;
    const auto cu = static_cast<uint32_t>(std::lround(std::floor(l.p.dot(layout.u_axis) / resolution)));
    const auto cv = static_cast<uint32_t>(std::lround(std::floor(l.p.dot(layout.v_axis) / resolution)));
    columns.insert(uint64_t{cu} << 32 | cv);
  }
  const double footprint = static_cast<double>(columns.size()) * resolution * resolution;
  double cut = std::numeric_limits<double>::infinity();
  for (auto it = bin_cover.rbegin(); it != bin_cover.rend(); ++it) {
    if (it->second < min_cover * footprint) break;
    cut = it->first * resolution;
  }
  // A map that is one flat layer (a floor only) has no ceiling.
  return cut <= bin_cover.begin()->first * resolution ? std::numeric_limits<double>::infinity() : cut;
}

MapPictureLayout makeAxes(const Vec3& up) {
  MapPictureLayout layout;
  Vec3 u = Vec3::UnitX() - up * up.dot(Vec3::UnitX());
  if (u.norm() < 0.3) u = Vec3::UnitZ() - up * up.dot(Vec3::UnitZ());
  layout.u_axis = u.normalized();
  layout.v_axis = (-up).cross(layout.u_axis).normalized();  // u x v = -up: seen from above
  return layout;
}

Status fitLayout(const std::vector<Leaf>& drawn, const std::vector<NamedTrajectory>& trajectories,
                 const MapPictureOptions& o, double resolution, MapPictureLayout* layout) {
  double u_min = INFINITY, u_max = -INFINITY, v_min = INFINITY, v_max = -INFINITY;
  auto extend = [&](const Vec3& p, double half) {
    const double u = p.dot(layout->u_axis), v = p.dot(layout->v_axis);
    u_min = std::min(u_min, u - half), u_max = std::max(u_max, u + half);
    v_min = std::min(v_min, v - half), v_max = std::max(v_max, v + half);
  };
  for (const Leaf& l : drawn) extend(l.p, l.size / 2);
  for (const auto& [name, poses] : trajectories)
    for (const SE3& T : poses) extend(T.translation(), 0.0);
  if (!(u_min <= u_max))
    return Status::failure("map picture: nothing to draw (no leaves, no trajectory poses)");
  const double extent = std::max({u_max - u_min, v_max - v_min, resolution});
  const int inner_px = std::max(1, o.max_side_px - 2 * o.margin_px);
  layout->pixel_m = o.pixel_m > 0.0 ? o.pixel_m : extent / inner_px;
  const double w = std::ceil((u_max - u_min) / layout->pixel_m) + 2.0 * o.margin_px;
  const double h = std::ceil((v_max - v_min) / layout->pixel_m) + 2.0 * o.margin_px;
  if (!(w <= kMaxSidePx && h <= kMaxSidePx))
    return Status::failure("map picture: pixel_m too small, the picture would exceed 10000 px");
  layout->width_px = static_cast<int>(w);
  layout->height_px = static_cast<int>(h);
  layout->u0 = u_min - o.margin_px * layout->pixel_m;
  layout->v0 = v_min - o.margin_px * layout->pixel_m;
  return Status::success();
}

void fillLeaf(cv::Mat* image, const MapPictureLayout& layout, const Leaf& l, const cv::Scalar& colour) {
  const cv::Point2d c = layout.toPixel(l.p);
  const double half = std::max(0.5, l.size / layout.pixel_m / 2.0);
  const cv::Point a(static_cast<int>(std::floor(c.x - half)), static_cast<int>(std::floor(c.y - half)));
  const cv::Point b(static_cast<int>(std::ceil(c.x + half)) - 1, static_cast<int>(std::ceil(c.y + half)) - 1);
  cv::rectangle(*image, a, cv::Point(std::max(a.x, b.x), std::max(a.y, b.y)), colour, cv::FILLED);
}

/// The height colours: turbo without its darkest blues (index < 35), which would hide the trajectories'
/// outlines; t in [0, 1] from the lowest to the highest occupied leaf.
cv::Scalar heightColour(double t) {
  static const cv::Mat lut = [] {
    cv::Mat ramp(1, 256, CV_8UC1), out;
    for (int i = 0; i < 256; ++i) ramp.at<uint8_t>(0, i) = static_cast<uint8_t>(i);
    cv::applyColorMap(ramp, out, cv::COLORMAP_TURBO);
    return out;
  }();
  const cv::Vec3b c =
      lut.at<cv::Vec3b>(0, 35 + static_cast<int>(std::lround(220.0 * std::clamp(t, 0.0, 1.0))));
  return cv::Scalar(c[0], c[1], c[2]);
}

/// Draws the occupied leaves, highest on top; returns their height range (lo > hi when there are none).
std::pair<double, double> drawOccupied(cv::Mat* image, const MapPictureLayout& layout,
                                       std::vector<Leaf> occupied) {
  if (occupied.empty()) return {1.0, 0.0};
  std::sort(occupied.begin(), occupied.end(),
            [](const Leaf& a, const Leaf& b) { return a.height < b.height; });
  const double lo = occupied.front().height, hi = occupied.back().height;
  for (const Leaf& l : occupied)
    fillLeaf(image, layout, l, heightColour(hi > lo ? (l.height - lo) / (hi - lo) : 0.5));
  return {lo, hi};
}

void label(cv::Mat* image, const std::string& text, cv::Point at, double scale = 0.45) {
  const int font = cv::FONT_HERSHEY_SIMPLEX;
  cv::putText(*image, text, at, font, scale, cv::Scalar(255, 255, 255), 3, cv::LINE_AA);
  cv::putText(*image, text, at, font, scale, cv::Scalar(0, 0, 0), 1, cv::LINE_AA);
}

/// Bottom right: the height colour bar, its range in metres along the map's up axis.
void drawHeightBar(cv::Mat* image, double lo, double hi) {
  if (lo > hi || image->rows < 160 || image->cols < 200) return;
  const int w = 14, h = std::min(120, image->rows / 3), x0 = image->cols - 80, y0 = image->rows - h - 16;
  cv::rectangle(*image, cv::Point(x0 - 4, y0 - 22), cv::Point(image->cols - 4, y0 + h + 10),
                cv::Scalar(255, 255, 255), cv::FILLED);
  for (int y = 0; y < h; ++y)
    cv::line(*image, cv::Point(x0, y0 + y), cv::Point(x0 + w, y0 + y),
             heightColour(1.0 - double(y) / (h - 1)));
  std::ostringstream top, bottom;
  top << std::fixed << std::setprecision(2) << hi << " m";
  bottom << std::fixed << std::setprecision(2) << lo << " m";
  label(image, "height", cv::Point(x0 - 2, y0 - 8));
  label(image, top.str(), cv::Point(x0 + w + 4, y0 + 10), 0.4);
  label(image, bottom.str(), cv::Point(x0 + w + 4, y0 + h), 0.4);
}

/// Top right: the map frame's x and y axes as arrows, and the frame's name.
void drawAxes(cv::Mat* image, const MapPictureLayout& layout) {
  if (image->cols < 200) return;
  const cv::Point origin(image->cols - 50, 50);
  const int len = 30;
  for (const auto& [axis, name] : {std::pair<Vec3, const char*>{Vec3::UnitX(), "x"}, {Vec3::UnitY(), "y"}}) {
    const cv::Point2d d(axis.dot(layout.u_axis), axis.dot(layout.v_axis));
    if (std::hypot(d.x, d.y) < 0.1) continue;  // the axis points out of the picture
    const cv::Point2d unit = d / std::hypot(d.x, d.y);
    const cv::Point tip = origin + cv::Point(static_cast<int>(len * unit.x), static_cast<int>(len * unit.y));
    cv::arrowedLine(*image, origin, tip, cv::Scalar(0, 0, 0), 2, cv::LINE_AA, 0, 0.25);
    label(image, name, tip + cv::Point(static_cast<int>(8 * unit.x) - 4, static_cast<int>(8 * unit.y) + 5));
  }
  label(image, "map frame", cv::Point(image->cols - 92, 72));
}

cv::Point px(const cv::Point2d& p) {
  return cv::Point(static_cast<int>(std::floor(p.x)), static_cast<int>(std::floor(p.y)));
}

void drawTrajectories(cv::Mat* image, const MapPictureLayout& layout,
                      const std::vector<NamedTrajectory>& trajectories, const MapPictureOptions& o) {
  const int t = o.trajectory_thickness_px;
  for (size_t k = 0; k < trajectories.size(); ++k) {
    const auto& poses = trajectories[k].second;
    if (poses.empty()) continue;
    std::vector<cv::Point> line;
    for (const SE3& T : poses) line.push_back(px(layout.toPixel(T.translation())));
    const auto& rgb = o.trajectory_rgb[k % o.trajectory_rgb.size()];
    const cv::Scalar colour = bgr(rgb);
    // Outline in black, or in white for a dark colour, so the line stands out on any map colour.
    const bool dark = 0.299 * rgb[0] + 0.587 * rgb[1] + 0.114 * rgb[2] < 60.0;
    const cv::Scalar outline = dark ? cv::Scalar(255, 255, 255) : cv::Scalar(0, 0, 0);
    cv::polylines(*image, line, false, outline, t + 2, cv::LINE_8);
    cv::polylines(*image, line, false, colour, t, cv::LINE_8);
    cv::circle(*image, line.front(), 2 * t + 2, outline, cv::FILLED, cv::LINE_AA);
    cv::circle(*image, line.front(), 2 * t, colour, cv::FILLED, cv::LINE_AA);
  }
}

void drawLegend(cv::Mat* image, const std::vector<NamedTrajectory>& trajectories,
                const MapPictureOptions& o) {
  const int font = cv::FONT_HERSHEY_SIMPLEX, row_px = 20;
  for (size_t k = 0; k < trajectories.size(); ++k) {
    const int y = 16 + static_cast<int>(k) * row_px;
    const cv::Scalar colour = bgr(o.trajectory_rgb[k % o.trajectory_rgb.size()]);
    cv::rectangle(*image, cv::Point(6, y - 10), cv::Point(28, y + 4), cv::Scalar(255, 255, 255), cv::FILLED);
    cv::line(*image, cv::Point(8, y - 3), cv::Point(26, y - 3), colour, o.trajectory_thickness_px);
    cv::putText(*image, trajectories[k].first, cv::Point(32, y + 2), font, 0.5, cv::Scalar(255, 255, 255), 3,
                cv::LINE_AA);
    cv::putText(*image, trajectories[k].first, cv::Point(32, y + 2), font, 0.5, cv::Scalar(0, 0, 0), 1,
                cv::LINE_AA);
  }
}

/// A bar of 1, 2 or 5 x 10^k metres, about a fifth of the picture wide, bottom left.
void drawScaleBar(cv::Mat* image, const MapPictureLayout& layout) {
  const double target_m = layout.width_px * layout.pixel_m / 5.0;
  const double decade = std::pow(10.0, std::floor(std::log10(target_m)));
  double length_m = decade;
  for (double f : {2.0, 5.0})
    if (f * decade <= target_m) length_m = f * decade;
  const int len_px = std::max(1, static_cast<int>(std::lround(length_m / layout.pixel_m)));
  const int x0 = 10, y0 = image->rows - 12;
  cv::rectangle(*image, cv::Point(x0 - 2, y0 - 22), cv::Point(x0 + len_px + 2, y0 + 4),
                cv::Scalar(255, 255, 255), cv::FILLED);
  cv::rectangle(*image, cv::Point(x0, y0 - 3), cv::Point(x0 + len_px, y0), cv::Scalar(0, 0, 0), cv::FILLED);
  std::ostringstream label;
  label << length_m << " m";
  cv::putText(*image, label.str(), cv::Point(x0, y0 - 8), cv::FONT_HERSHEY_SIMPLEX, 0.45, cv::Scalar(0, 0, 0),
              1, cv::LINE_AA);
}

}  // namespace

std::string MapPictureOptions::validate() const {
  std::vector<std::string> bad;
  if (max_side_px < 100 || max_side_px > kMaxSidePx) bad.push_back("max_side_px must be in [100, 10000]");
  if (!(up_in_map.allFinite() && up_in_map.norm() > 1e-6))
    bad.push_back("up_in_map must be a finite non-zero vector");
  if (!(std::isfinite(pixel_m) && pixel_m >= 0.0)) bad.push_back("pixel_m must be >= 0 (0 = auto)");
  if (margin_px < 0 || 2 * margin_px >= max_side_px)
    bad.push_back("margin_px must be in [0, max_side_px / 2)");
  if (std::isnan(min_height_m) || std::isnan(max_height_m) || !(min_height_m < max_height_m))
    bad.push_back("min_height_m must be < max_height_m");
  if (!(ceiling_min_cover >= 0.0 && ceiling_min_cover <= 1.0))
    bad.push_back("ceiling_min_cover must be in [0, 1]");
  if (trajectory_rgb.empty()) bad.push_back("trajectory_rgb must not be empty");
  if (trajectory_thickness_px < 1 || trajectory_thickness_px > 20)
    bad.push_back("trajectory_thickness_px must be in [1, 20]");
  std::string out;
  for (const std::string& b : bad) out += (out.empty() ? "" : "; ") + b;
  return out;
}

cv::Point2d MapPictureLayout::toPixel(const Vec3& p_map) const {
  return cv::Point2d((p_map.dot(u_axis) - u0) / pixel_m, (p_map.dot(v_axis) - v0) / pixel_m);
}

Result<cv::Mat> renderMapPicture(const octomap::OcTree& tree,
                                 const std::vector<NamedTrajectory>& trajectories,
                                 const MapPictureOptions& options, MapPictureLayout* layout_out) {
  using R = Result<cv::Mat>;
  if (const std::string bad = options.validate(); !bad.empty())
    return R::failure("map picture options: " + bad);
  for (const auto& [name, poses] : trajectories)
    for (const SE3& T : poses)
      if (!T.matrix().allFinite())
        return R::failure("map picture: trajectory '" + name + "' has a non-finite pose");
  const Vec3 up = options.up_in_map.normalized();
  MapPictureLayout layout = makeAxes(up);
  Leaves leaves = collectLeaves(tree, up);
  const double cut = std::min(options.max_height_m, ceilingCut(leaves.occupied, layout, tree.getResolution(),
                                                               options.ceiling_min_cover));
  std::vector<Leaf> occupied;
  for (const Leaf& l : leaves.occupied)
    if (l.height >= options.min_height_m && l.height < cut) occupied.push_back(l);
  std::vector<Leaf> footprint = occupied;
  footprint.insert(footprint.end(), leaves.free.begin(), leaves.free.end());
  if (Status s = fitLayout(footprint, trajectories, options, tree.getResolution(), &layout); !s)
    return R::failure(s.error());

  cv::Mat image(layout.height_px, layout.width_px, CV_8UC3, bgr(options.unknown_rgb));
  for (const Leaf& l : leaves.free) fillLeaf(&image, layout, l, bgr(options.free_rgb));
  const auto [lo, hi] = drawOccupied(&image, layout, std::move(occupied));
  drawTrajectories(&image, layout, trajectories, options);
  drawLegend(&image, trajectories, options);
  drawScaleBar(&image, layout);
  drawHeightBar(&image, lo, hi);
  drawAxes(&image, layout);
  if (layout_out) *layout_out = layout;
  return image;
}

Status writeMapPicture(const octomap::OcTree& tree, const std::vector<NamedTrajectory>& trajectories,
                       const std::string& png_path, const MapPictureOptions& options) {
  auto image = renderMapPicture(tree, trajectories, options);
  if (!image) return Status::failure(image.error());
  std::vector<uchar> png;
  try {
    if (!cv::imencode(".png", *image, png)) return Status::failure("map picture: PNG encoding failed");
  } catch (const cv::Exception& e) {
    return Status::failure(std::string("map picture: PNG encoding failed: ") + e.what());
  }
  Status s = export_detail::writeFileAtomically(png_path, std::string(png.begin(), png.end()));
  return s ? s : Status::failure("map picture: " + s.error());
}

}  // namespace rgbdmap
