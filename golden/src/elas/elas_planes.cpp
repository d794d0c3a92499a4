// libelas disparity planes: Numerical-Recipes Gauss-Jordan in double, stored as float (docs/ALGORITHM.md, elas mode).
#include <cmath>
#include <utility>

#include "ielas/elas.hpp"

namespace ielas {
namespace elas {

bool gaussJordanSolve(double A[3][3], double b[3]) {
  constexpr int n = 3;
  constexpr double kSingular = 1e-20;
  int ipiv[n] = {0, 0, 0};
  for (int i = 0; i < n; ++i) {
    double big = 0.0;
    int irow = 0, icol = 0;
    // Full pivot search; ">=" lets the last maximal element win, as in libelas's Matrix::solve.
    for (int j = 0; j < n; ++j)
      if (ipiv[j] != 1)
        for (int k = 0; k < n; ++k)
          if (ipiv[k] == 0 && std::fabs(A[j][k]) >= big) {
            big = std::fabs(A[j][k]);
            irow = j;
            icol = k;
          }
    ++ipiv[icol];
    if (irow != icol) {
      for (int l = 0; l < n; ++l) std::swap(A[irow][l], A[icol][l]);
      std::swap(b[irow], b[icol]);
    }
    if (std::fabs(A[icol][icol]) < kSingular) return false;
    const double pivinv = 1.0 / A[icol][icol];
    A[icol][icol] = 1.0;
    for (int l = 0; l < n; ++l) A[icol][l] *= pivinv;
    b[icol] *= pivinv;
    for (int ll = 0; ll < n; ++ll)
      if (ll != icol) {
        const double dum = A[ll][icol];
        A[ll][icol] = 0.0;
        for (int l = 0; l < n; ++l) A[ll][l] -= A[icol][l] * dum;
        b[ll] -= b[icol] * dum;
      }
  }
  // Unscrambling the column interchanges touches only A (the inverse), never the solution b.
  return true;
}

void computePlanes(const std::vector<SupportPoint>& points, std::vector<Triangle>& triangles, View view) {
  (void)view;  // both planes are solved per triangle, whichever mesh it belongs to, as libelas does
  for (Triangle& t : triangles) {
    const SupportPoint* p[3] = {&points[t.c1], &points[t.c2], &points[t.c3]};
    for (int image = 0; image < 2; ++image) {
      double A[3][3], b[3];
      for (int k = 0; k < 3; ++k) {
        A[k][0] = image == 0 ? p[k]->u : p[k]->u - p[k]->d;
        A[k][1] = p[k]->v;
        A[k][2] = 1;
        b[k] = p[k]->d;
      }
      float a = 0, bb = 0, c = 0;  // a singular system gives the plane (0, 0, 0)
      if (gaussJordanSolve(A, b)) {
        a = static_cast<float>(b[0]);
        bb = static_cast<float>(b[1]);
        c = static_cast<float>(b[2]);
      }
      if (image == 0) {
        t.t1a = a; t.t1b = bb; t.t1c = c;
      } else {
        t.t2a = a; t.t2b = bb; t.t2c = c;
      }
    }
  }
}

}  // namespace elas
}  // namespace ielas
