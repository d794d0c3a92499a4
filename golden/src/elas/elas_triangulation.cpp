// Delaunay triangulation of the support points, own code: incremental Bowyer-Watson with ghost triangles for the
// convex hull and exact integer predicates. libelas uses Shewchuk's Triangle; the triangle set is the same up to
// the choice of diagonal among cocircular points, the triangle order is not (docs/ALGORITHM.md, elas mode).
#include <algorithm>
#include <cstdint>
#include <set>
#include <utility>

#include "ielas/elas.hpp"

namespace ielas {
namespace elas {

namespace {

constexpr int kInfinite = -1;  // the ghost vertex: ghost (x, y, inf) has the hull's outside left of x -> y

struct Vertex {
  int64_t x, y;
};

int64_t orient(const Vertex& a, const Vertex& b, const Vertex& c) {
  return (b.x - a.x) * (c.y - a.y) - (b.y - a.y) * (c.x - a.x);
}

// > 0 when d lies strictly inside the circle through a, b, c (counter-clockwise, orient > 0).
int64_t inCircle(const Vertex& a, const Vertex& b, const Vertex& c, const Vertex& d) {
  const int64_t adx = a.x - d.x, ady = a.y - d.y, bdx = b.x - d.x, bdy = b.y - d.y, cdx = c.x - d.x, cdy = c.y - d.y;
  return (adx * adx + ady * ady) * (bdx * cdy - bdy * cdx) + (bdx * bdx + bdy * bdy) * (cdx * ady - cdy * adx) +
         (cdx * cdx + cdy * cdy) * (adx * bdy - ady * bdx);
}

struct Tri {
  int v[3];  // counter-clockwise; v[2] == kInfinite for a ghost
  int n[3];  // n[k]: the triangle across the edge opposite v[k]
  bool alive;
};

class Triangulator {
 public:
  explicit Triangulator(const std::vector<Vertex>& pts) : pts_(pts) {}

  // Returns false if all points are collinear (then there is no triangle).
  bool run(const std::vector<int>& order) {
    if (order.size() < 3) return false;
    const int a = order[0], b = order[1];
    size_t third = 2;
    while (third < order.size() && orient(pts_[a], pts_[b], pts_[order[third]]) == 0) ++third;
    if (third == order.size()) return false;
    int c = order[third];
    int p0 = a, p1 = b;
    if (orient(pts_[a], pts_[b], pts_[c]) < 0) std::swap(p0, p1);
    // Real triangle 0 and the three ghosts across its edges.
    tris_.push_back({{p0, p1, c}, {2, 3, 1}, true});
    tris_.push_back({{p1, p0, kInfinite}, {-1, -1, 0}, true});  // across edge p0-p1 (opposite c)
    tris_.push_back({{c, p1, kInfinite}, {-1, -1, 0}, true});   // across edge p1-c (opposite p0)
    tris_.push_back({{p0, c, kInfinite}, {-1, -1, 0}, true});   // across edge c-p0 (opposite p1)
    linkAll();
    for (size_t k = 2; k < order.size(); ++k)
      if (k != third) insert(order[k]);
    return true;
  }

  std::vector<Triangle> triangles() const {
    std::vector<Triangle> out;
    for (const Tri& t : tris_)
      if (t.alive && t.v[2] != kInfinite) out.push_back({t.v[0], t.v[1], t.v[2]});
    return out;
  }

 private:
  bool conflicts(int t, const Vertex& p) const {
    const Tri& tri = tris_[t];
    if (tri.v[2] != kInfinite) return inCircle(pts_[tri.v[0]], pts_[tri.v[1]], pts_[tri.v[2]], p) > 0;
    const Vertex& x = pts_[tri.v[0]];
    const Vertex& y = pts_[tri.v[1]];
    const int64_t o = orient(x, y, p);
    if (o != 0) return o > 0;
    // On the hull line: a conflict only strictly between x and y, so that the hull edge is split.
    const int64_t dot1 = (p.x - x.x) * (y.x - x.x) + (p.y - x.y) * (y.y - x.y);
    const int64_t dot2 = (p.x - y.x) * (x.x - y.x) + (p.y - y.y) * (x.y - y.y);
    return dot1 > 0 && dot2 > 0;
  }

  // Neighbour links of the initial four triangles by shared edges.
  void linkAll() {
    for (size_t t = 0; t < tris_.size(); ++t)
      for (int k = 0; k < 3; ++k) {
        const int e1 = tris_[t].v[(k + 1) % 3], e2 = tris_[t].v[(k + 2) % 3];
        for (size_t s = 0; s < tris_.size(); ++s) {
          if (s == t) continue;
          for (int m = 0; m < 3; ++m)
            if (tris_[s].v[(m + 1) % 3] == e2 && tris_[s].v[(m + 2) % 3] == e1) tris_[t].n[k] = static_cast<int>(s);
        }
      }
  }

  int locate(const Vertex& p) {
    int t = last_;
    const int limit = 4 * static_cast<int>(tris_.size()) + 16;
    for (int steps = 0; steps < limit; ++steps) {
      const Tri& tri = tris_[t];
      if (tri.v[2] == kInfinite) {
        if (conflicts(t, p)) return t;
        break;
      }
      int next = -1;
      for (int i = 0; i < 3; ++i) {
        const int k = (i + steps) % 3;  // rotate the first edge tried to avoid cycling
        if (orient(pts_[tri.v[(k + 1) % 3]], pts_[tri.v[(k + 2) % 3]], p) < 0) {
          next = tri.n[k];
          break;
        }
      }
      if (next < 0) return t;  // p inside or on the boundary of a real triangle
      t = next;
    }
    for (size_t s = 0; s < tris_.size(); ++s)  // fallback, never expected
      if (tris_[s].alive && conflicts(static_cast<int>(s), p)) return static_cast<int>(s);
    return -1;
  }

  void insert(int pi) {
    const Vertex& p = pts_[pi];
    const int start = locate(p);
    if (start < 0) return;
    ++stamp_;
    if (mark_.size() < tris_.size()) mark_.resize(tris_.size() * 2, 0), state_.resize(tris_.size() * 2, 0);
    cavity_.clear();
    boundary_.clear();
    cavity_.push_back(start);
    mark_[start] = stamp_;
    state_[start] = 1;
    for (size_t i = 0; i < cavity_.size(); ++i) {
      const int t = cavity_[i];
      for (int k = 0; k < 3; ++k) {
        const int nb = tris_[t].n[k];
        if (mark_[nb] != stamp_) {
          mark_[nb] = stamp_;
          state_[nb] = conflicts(nb, p) ? 1 : 0;
          if (state_[nb]) cavity_.push_back(nb);
        }
        if (!state_[nb]) boundary_.push_back({t, k});
      }
    }
    // One new triangle (e1, e2, p) per boundary edge.
    const size_t first = tris_.size();
    for (const auto& edge : boundary_) {
      const Tri& t = tris_[edge.first];
      const int e1 = t.v[(edge.second + 1) % 3], e2 = t.v[(edge.second + 2) % 3], outer = t.n[edge.second];
      tris_.push_back({{e1, e2, pi}, {-1, -1, outer}, true});
      Tri& o = tris_[outer];
      for (int m = 0; m < 3; ++m)
        if (o.n[m] == edge.first) o.n[m] = static_cast<int>(tris_.size() - 1);
    }
    for (int t : cavity_) tris_[t].alive = false;
    for (size_t a = first; a < tris_.size(); ++a)
      for (size_t b = first; b < tris_.size(); ++b) {
        if (tris_[b].v[0] == tris_[a].v[1]) tris_[a].n[0] = static_cast<int>(b);  // across edge e2 -> p
        if (tris_[b].v[1] == tris_[a].v[0]) tris_[a].n[1] = static_cast<int>(b);  // across edge p -> e1
      }
    // Keep the ghost vertex in slot 2.
    for (size_t a = first; a < tris_.size(); ++a) {
      Tri& t = tris_[a];
      while (t.v[2] == kInfinite ? false : (t.v[0] == kInfinite || t.v[1] == kInfinite)) {
        std::rotate(t.v, t.v + 1, t.v + 3);
        std::rotate(t.n, t.n + 1, t.n + 3);
      }
    }
    if (mark_.size() < tris_.size()) mark_.resize(tris_.size() * 2, 0), state_.resize(tris_.size() * 2, 0);
    for (size_t a = first; a < tris_.size(); ++a)
      if (tris_[a].v[2] != kInfinite) last_ = static_cast<int>(a);
  }

  const std::vector<Vertex>& pts_;
  std::vector<Tri> tris_;
  std::vector<int> cavity_;
  std::vector<std::pair<int, int>> boundary_;
  std::vector<int> mark_;
  std::vector<uint8_t> state_;
  int stamp_ = 0;
  int last_ = 0;
};

}  // namespace

std::vector<Triangle> delaunayTriangulation(const std::vector<cv::Point>& points) {
  std::vector<Vertex> pts;
  pts.reserve(points.size());
  for (const cv::Point& p : points) pts.push_back({p.x, p.y});
  // Triangle drops duplicate vertices; here the first occurrence in list order is kept.
  std::vector<int> order;
  std::set<std::pair<int, int>> seen;
  for (size_t i = 0; i < points.size(); ++i)
    if (seen.insert({points[i].x, points[i].y}).second) order.push_back(static_cast<int>(i));
  Triangulator triangulator(pts);
  if (!triangulator.run(order)) return {};
  return triangulator.triangles();
}

std::vector<Triangle> triangulateSupport(const std::vector<SupportPoint>& points, View view) {
  std::vector<cv::Point> vertices;
  vertices.reserve(points.size());
  for (const SupportPoint& p : points) vertices.emplace_back(view == View::Left ? p.u : p.u - p.d, p.v);
  return delaunayTriangulation(vertices);
}

}  // namespace elas
}  // namespace ielas
