#include "eval/assignment.h"

#include <gtest/gtest.h>

#include <algorithm>
#include <numeric>
#include <random>

#include "common/error.h"

namespace cofusion::eval {
namespace {

// Smallest total over every injective map of the smaller side into the larger.
double brute_force_min(const Eigen::MatrixXd& cost) {
  const bool transpose = cost.rows() > cost.cols();
  const Eigen::MatrixXd c = transpose ? Eigen::MatrixXd(cost.transpose()) : cost;
  const int n = static_cast<int>(c.rows()), m = static_cast<int>(c.cols());
  std::vector<int> cols(static_cast<std::size_t>(m));
  std::iota(cols.begin(), cols.end(), 0);
  double best = std::numeric_limits<double>::infinity();
  // Every permutation of the columns; its first n entries are an injective map.
  do {
    double total = 0;
    for (int i = 0; i < n; ++i) total += c(i, cols[static_cast<std::size_t>(i)]);
    best = std::min(best, total);
  } while (std::next_permutation(cols.begin(), cols.end()));
  return best;
}

double total_of(const Eigen::MatrixXd& cost, const std::vector<int>& assignment) {
  double total = 0;
  for (std::size_t i = 0; i < assignment.size(); ++i)
    if (assignment[i] >= 0) total += cost(static_cast<Eigen::Index>(i), assignment[i]);
  return total;
}

TEST(Assignment, MatchesBruteForceOnRandomMatrices) {
  std::mt19937 rng(42);
  std::uniform_real_distribution<double> value(-1.0, 5.0);
  std::uniform_int_distribution<int> size(1, 6);
  std::uniform_int_distribution<int> small_int(0, 3);
  for (int trial = 0; trial < 400; ++trial) {
    const int rows = size(rng), cols = size(rng);
    Eigen::MatrixXd cost(rows, cols);
    // Half the trials use small integers, so ties are common.
    for (int r = 0; r < rows; ++r)
      for (int c = 0; c < cols; ++c) cost(r, c) = trial % 2 ? value(rng) : small_int(rng);
    const std::vector<int> a = solve_min_cost_assignment(cost);
    ASSERT_EQ(a.size(), static_cast<std::size_t>(rows));
    // Valid: distinct columns, exactly min(rows, cols) rows assigned.
    std::vector<int> used;
    for (const int c : a)
      if (c >= 0) {
        ASSERT_LT(c, cols);
        used.push_back(c);
      }
    std::sort(used.begin(), used.end());
    EXPECT_EQ(std::adjacent_find(used.begin(), used.end()), used.end());
    EXPECT_EQ(static_cast<int>(used.size()), std::min(rows, cols));
    EXPECT_NEAR(total_of(cost, a), brute_force_min(cost), 1e-9) << "trial " << trial << "\n" << cost;
  }
}

TEST(Assignment, MaximisesScore) {
  Eigen::MatrixXd score(3, 3);
  score << 0.9, 0.8, 0.0,  //
      0.85, 0.1, 0.0,      //
      0.0, 0.0, 0.5;
  // Greedy would take (0,0) = 0.9 and leave row 1 with 0.1; optimal is 0.8 + 0.85 + 0.5.
  const auto a = solve_max_score_assignment(score);
  EXPECT_EQ(a, (std::vector<int>{1, 0, 2}));
}

TEST(Assignment, EmptyAndNonFinite) {
  EXPECT_TRUE(solve_min_cost_assignment(Eigen::MatrixXd(0, 0)).empty());
  EXPECT_EQ(solve_min_cost_assignment(Eigen::MatrixXd(2, 0)), (std::vector<int>{-1, -1}));
  Eigen::MatrixXd bad(1, 1);
  bad(0, 0) = std::numeric_limits<double>::quiet_NaN();
  EXPECT_THROW(solve_min_cost_assignment(bad), Error);
}

}  // namespace
}  // namespace cofusion::eval
