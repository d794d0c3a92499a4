// libelas disparity-candidate grid with its linear-walk dilation (docs/ALGORITHM.md, elas mode).
#include <algorithm>
#include <cmath>

#include "ielas/elas.hpp"

namespace ielas {
namespace elas {

namespace {
int floorDiv(int a, int b) { return a >= 0 ? a / b : -((-a + b - 1) / b); }
}  // namespace

CandidateGrid candidateGrid(const std::vector<SupportPoint>& points, int width, int height, View view,
                            const Config& cfg) {
  const int cols = (width + cfg.gridSize - 1) / cfg.gridSize, rows = (height + cfg.gridSize - 1) / cfg.gridSize;
  const int depth = cfg.dispMax + 1, cells = rows * cols;
  std::vector<uint8_t> marks(static_cast<size_t>(cells) * depth, 0);
  for (const SupportPoint& p : points) {
    const int x = floorDiv(view == View::Left ? p.u : p.u - p.d, cfg.gridSize);
    const int y = floorDiv(p.v, cfg.gridSize);
    if (x < 0 || x >= cols || y < 0 || y >= rows) continue;  // corner points may lie outside
    for (int d = std::max(p.d - 1, 0); d <= std::min(p.d + 1, cfg.dispMax); ++d)
      marks[(static_cast<size_t>(y) * cols + x) * depth + d] = 1;
  }

  // QUIRK: libelas dilates by walking the cells as one linear array, so only cells cols+1 .. cells-cols-2 are
  // written and column 0 / cols-1 neighbours wrap into the adjacent grid row. The rest stays empty.
  std::vector<uint8_t> dilated(marks.size(), 0);
  const int offsets[9] = {-cols - 1, -cols, -cols + 1, -1, 0, 1, cols - 1, cols, cols + 1};
  for (int cell = cols + 1; cell <= cells - cols - 2; ++cell)
    for (int d = 0; d < depth; ++d) {
      uint8_t any = 0;
      for (int o : offsets) any |= marks[static_cast<size_t>(cell + o) * depth + d];
      dilated[static_cast<size_t>(cell) * depth + d] = any;
    }

  CandidateGrid grid;
  grid.rows = rows;
  grid.cols = cols;
  grid.depth = depth;
  grid.counts.assign(cells, 0);
  grid.lists.assign(static_cast<size_t>(cells) * depth, -1);
  for (int cell = 0; cell < cells; ++cell) {
    int n = 0;
    for (int d = 0; d < depth; ++d)
      if (dilated[static_cast<size_t>(cell) * depth + d]) grid.lists[static_cast<size_t>(cell) * depth + n++] = d;
    grid.counts[cell] = n;
  }
  return grid;
}

}  // namespace elas
}  // namespace ielas
