#pragma once
// Optimal one-to-one assignment (Hungarian / Kuhn-Munkres with potentials, O(n^2 m)) on a
// rectangular cost matrix. Used to match estimated segmentation labels to ground-truth instances
// (maximising IoU) and estimated object models to ground-truth objects (minimising ATE).
#include <Eigen/Core>
#include <vector>

namespace cofusion::eval {

// Minimises the total cost over assignments that pair min(rows, cols) rows with distinct columns.
// Returns, for each row, its column or -1 (only when rows > cols). Costs must be finite.
std::vector<int> solve_min_cost_assignment(const Eigen::MatrixXd& cost);

// Same on a score matrix, maximising the total score.
std::vector<int> solve_max_score_assignment(const Eigen::MatrixXd& score);

}  // namespace cofusion::eval
