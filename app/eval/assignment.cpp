#include "eval/assignment.h"

#include <cmath>
#include <limits>
#include <string>

#include "common/error.h"

namespace cofusion::eval {
namespace {

// Rows <= cols. The classic shortest-augmenting-path formulation with row/column potentials:
// each row is inserted in turn and the assignment is extended along a Dijkstra-like search.
std::vector<int> assign_rows_le_cols(const Eigen::MatrixXd& cost) {
  const int n = static_cast<int>(cost.rows());
  const int m = static_cast<int>(cost.cols());
  const double inf = std::numeric_limits<double>::infinity();
  // 1-based arrays; column 0 is a virtual column holding the row being inserted.
  std::vector<double> u(n + 1, 0.0), v(m + 1, 0.0);
  std::vector<int> row_of_col(m + 1, 0), way(m + 1, 0);
  for (int i = 1; i <= n; ++i) {
    row_of_col[0] = i;
    int j0 = 0;
    std::vector<double> min_slack(m + 1, inf);
    std::vector<char> used(m + 1, 0);
    do {
      used[j0] = 1;
      const int i0 = row_of_col[j0];
      double delta = inf;
      int j1 = 0;
      for (int j = 1; j <= m; ++j) {
        if (used[j]) continue;
        const double reduced = cost(i0 - 1, j - 1) - u[i0] - v[j];
        if (reduced < min_slack[j]) {
          min_slack[j] = reduced;
          way[j] = j0;
        }
        if (min_slack[j] < delta) {
          delta = min_slack[j];
          j1 = j;
        }
      }
      for (int j = 0; j <= m; ++j) {
        if (used[j]) {
          u[row_of_col[j]] += delta;
          v[j] -= delta;
        } else {
          min_slack[j] -= delta;
        }
      }
      j0 = j1;
    } while (row_of_col[j0] != 0);
    do {
      const int j1 = way[j0];
      row_of_col[j0] = row_of_col[j1];
      j0 = j1;
    } while (j0 != 0);
  }
  std::vector<int> col_of_row(n, -1);
  for (int j = 1; j <= m; ++j)
    if (row_of_col[j] != 0) col_of_row[row_of_col[j] - 1] = j - 1;
  return col_of_row;
}

}  // namespace

std::vector<int> solve_min_cost_assignment(const Eigen::MatrixXd& cost) {
  if (cost.size() == 0) return std::vector<int>(static_cast<std::size_t>(cost.rows()), -1);
  if (!cost.allFinite()) throw Error("assignment: cost matrix has non-finite entries");
  if (cost.rows() <= cost.cols()) return assign_rows_le_cols(cost);
  const std::vector<int> row_of_col = assign_rows_le_cols(cost.transpose());
  std::vector<int> col_of_row(static_cast<std::size_t>(cost.rows()), -1);
  for (std::size_t j = 0; j < row_of_col.size(); ++j)
    if (row_of_col[j] >= 0) col_of_row[static_cast<std::size_t>(row_of_col[j])] = static_cast<int>(j);
  return col_of_row;
}

std::vector<int> solve_max_score_assignment(const Eigen::MatrixXd& score) {
  return solve_min_cost_assignment(-score);
}

}  // namespace cofusion::eval
