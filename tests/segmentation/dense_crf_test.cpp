// The fully connected CRF: permutohedral filtering against explicit Gaussian sums, exact vs
// permutohedral inference, and what mean-field does on constructed cases.
#include <gtest/gtest.h>

#include <cmath>
#include <random>
#include <vector>

#include <tbb/task_arena.h>

#include "segmentation/dense_crf.h"
#include "segmentation/permutohedral.h"
#include "support/test_support.h"

namespace cofusion::segmentation {
namespace {

// Superpixel-like nodes on a gw x gh grid (jittered), four colour/depth regions with noise.
std::vector<CrfNode> grid_nodes(int gw, int gh, uint32_t seed, bool colour_regions = true) {
  std::mt19937 rng(seed);
  std::uniform_real_distribution<float> u(0.0f, 1.0f);
  std::vector<CrfNode> nodes;
  for (int y = 0; y < gh; ++y)
    for (int x = 0; x < gw; ++x) {
      const int region = colour_regions ? (x >= gw / 2) + 2 * (y >= gh / 2) : 0;
      CrfNode n;
      n.x = static_cast<float>(x) + 0.5f + 0.4f * (u(rng) - 0.5f);
      n.y = static_cast<float>(y) + 0.5f + 0.4f * (u(rng) - 0.5f);
      n.r = 40.0f + 50.0f * static_cast<float>(region) + 12.0f * u(rng);
      n.g = 120.0f + 12.0f * u(rng);
      n.b = 200.0f - 45.0f * static_cast<float>(region) + 12.0f * u(rng);
      n.depth_m = 1.0f + 0.3f * static_cast<float>(region) + 0.02f * u(rng);
      nodes.push_back(n);
    }
  return nodes;
}

std::vector<int> hard_labels(const std::vector<float>& q, int labels) {
  std::vector<int> out(q.size() / static_cast<size_t>(labels));
  for (size_t i = 0; i < out.size(); ++i) {
    int best = 0;
    for (int l = 1; l < labels; ++l)
      if (q[i * static_cast<size_t>(labels) + static_cast<size_t>(l)] > q[i * static_cast<size_t>(labels) + static_cast<size_t>(best)]) best = l;
    out[i] = best;
  }
  return out;
}

// The lattice approximates Gaussian sums up to a position-dependent scale (the blur is not a
// normalised Gaussian), which the CRF cancels by normalising with the filtered ones. So compare
// normalised filtering: a Gaussian-weighted average of a smooth signal, lattice vs explicit sums.
TEST(DenseCrf, AutoMethodFollowsTheJobSystemsThreads) {
  EXPECT_EQ(effective_method(CrfMethod::kAuto, 1), CrfMethod::kPermutohedral);
  EXPECT_EQ(effective_method(CrfMethod::kAuto, kExactMinThreads - 1), CrfMethod::kPermutohedral);
  EXPECT_EQ(effective_method(CrfMethod::kAuto, kExactMinThreads), CrfMethod::kExact);
  EXPECT_EQ(effective_method(CrfMethod::kExact, 1), CrfMethod::kExact);
  EXPECT_EQ(effective_method(CrfMethod::kPermutohedral, 64), CrfMethod::kPermutohedral);
  // Inside an arena of n threads kAuto infers exactly as the method it stands for there.
  const std::vector<CrfNode> nodes = grid_nodes(20, 15, 3);
  const int L = 3;
  std::vector<float> unary(nodes.size() * L);
  for (size_t k = 0; k < unary.size(); ++k) unary[k] = 0.1f * static_cast<float>((k * 7919) % 23);
  const auto infer = [&](CrfMethod method, int threads) {
    std::vector<float> q;
    tbb::task_arena(threads).execute([&] {
      CrfParams params;
      params.method = method;
      DenseCrf crf;
      crf.set_nodes(nodes, params);
      crf.infer(unary, L, q);
    });
    return q;
  };
  EXPECT_EQ(infer(CrfMethod::kAuto, 1), infer(CrfMethod::kPermutohedral, 1));
  EXPECT_EQ(infer(CrfMethod::kAuto, kExactMinThreads), infer(CrfMethod::kExact, kExactMinThreads));
  EXPECT_NE(infer(CrfMethod::kExact, 1), infer(CrfMethod::kPermutohedral, 1));  // the two differ at all
}

TEST(PermutohedralLattice, NormalisedFilteringMatchesGaussianAverages) {
  for (const int d : {2, 6}) {
    std::mt19937 rng(7);
    std::uniform_real_distribution<float> u(0.0f, 4.0f);
    const int n = 600;
    std::vector<float> f(static_cast<size_t>(n) * d), in(static_cast<size_t>(n) * 2), out(in.size());
    for (auto& v : f) v = u(rng);
    for (int i = 0; i < n; ++i) {
      in[static_cast<size_t>(2 * i)] = std::sin(f[static_cast<size_t>(i * d)]);  // the signal...
      in[static_cast<size_t>(2 * i + 1)] = 1.0f;                                 // ...and the ones
    }
    PermutohedralLattice lattice;
    lattice.init(f.data(), d, n);
    lattice.filter(in.data(), out.data(), 2);
    double err = 0, spread = 0;
    for (int i = 0; i < n; ++i) {
      double num = 0, den = 0;
      for (int j = 0; j < n; ++j) {
        double d2 = 0;
        for (int k = 0; k < d; ++k) {
          const double e = f[static_cast<size_t>(i * d + k)] - f[static_cast<size_t>(j * d + k)];
          d2 += e * e;
        }
        num += std::exp(-0.5 * d2) * in[static_cast<size_t>(2 * j)];
        den += std::exp(-0.5 * d2);
      }
      const double exact = num / den;
      const double approx = out[static_cast<size_t>(2 * i)] / out[static_cast<size_t>(2 * i + 1)];
      err += std::abs(approx - exact);
      spread += std::abs(exact - in[static_cast<size_t>(2 * i)]);  // how much filtering changed it
    }
    // Mean error well below the filtering's own effect and small in absolute terms (signal in [-1, 1]).
    EXPECT_LT(err / n, 0.08) << "d = " << d;
    EXPECT_LT(err, 0.5 * spread) << "d = " << d;
    EXPECT_GT(lattice.vertices(), 0);
  }
}

// The channels are filtered in groups where threads are plentiful: the output must not depend on
// the grouping (nor on the thread count), and equals filtering each channel on its own.
TEST(PermutohedralLattice, FilteringIsTheSameForAnyChannelGrouping) {
  std::mt19937 rng(11);
  std::uniform_real_distribution<float> u(0.0f, 4.0f);
  const int n = 500, d = 6, v = 7;
  std::vector<float> f(static_cast<size_t>(n) * d), in(static_cast<size_t>(n) * v);
  for (auto& x : f) x = u(rng);
  for (auto& x : in) x = u(rng) - 2.0f;
  PermutohedralLattice lattice;
  lattice.init(f.data(), d, n);
  const auto filtered = [&](int threads) {
    std::vector<float> out(in.size());
    tbb::task_arena(threads).execute([&] { lattice.filter(in.data(), out.data(), v); });
    return out;
  };
  const std::vector<float> one = filtered(1);
  for (const int threads : {2, 4, 6, 16}) EXPECT_EQ(filtered(threads), one) << threads << " threads";
  std::vector<float> channel_in(static_cast<size_t>(n)), channel_out(static_cast<size_t>(n));
  for (int c = 0; c < v; ++c) {
    for (int i = 0; i < n; ++i) channel_in[static_cast<size_t>(i)] = in[static_cast<size_t>(i * v + c)];
    lattice.filter(channel_in.data(), channel_out.data(), 1);
    for (int i = 0; i < n; ++i)
      ASSERT_EQ(channel_out[static_cast<size_t>(i)], one[static_cast<size_t>(i * v + c)]) << "channel " << c << ", point " << i;
  }
}

TEST(DenseCrf, ExactAndPermutohedralAgree) {
  const int gw = 40, gh = 30, L = 3;
  const std::vector<CrfNode> nodes = grid_nodes(gw, gh, 3);
  // Unaries: each region prefers one label (regions 0 and 3 share label 0), with heavy noise.
  std::mt19937 rng(11);
  std::normal_distribution<float> noise(0.0f, 1.2f);
  std::vector<float> unary(nodes.size() * L);
  for (size_t i = 0; i < nodes.size(); ++i) {
    const int x = static_cast<int>(i) % gw, y = static_cast<int>(i) / gw;
    const int region = (x >= gw / 2) + 2 * (y >= gh / 2);
    const int want = region % 3;
    for (int l = 0; l < L; ++l) unary[i * L + static_cast<size_t>(l)] = (l == want ? 0.5f : 2.0f) + noise(rng);
  }
  CrfParams params;
  params.method = CrfMethod::kExact;
  DenseCrf exact;
  exact.set_nodes(nodes, params);
  params.method = CrfMethod::kPermutohedral;
  DenseCrf lattice;
  lattice.set_nodes(nodes, params);

  // Messages for the initial marginals.
  std::vector<float> q(nodes.size() * L), m_exact(q.size()), m_lattice(q.size());
  for (size_t i = 0; i < nodes.size(); ++i) {
    float sum = 0;
    for (int l = 0; l < L; ++l) sum += q[i * L + static_cast<size_t>(l)] = std::exp(-unary[i * L + static_cast<size_t>(l)]);
    for (int l = 0; l < L; ++l) q[i * L + static_cast<size_t>(l)] /= sum;
  }
  exact.message(q, L, m_exact);
  lattice.message(q, L, m_lattice);
  double diff = 0, mag = 0;
  for (size_t k = 0; k < q.size(); ++k) {
    diff += std::abs(m_exact[k] - m_lattice[k]);
    mag += std::abs(m_exact[k]);
  }
  EXPECT_LT(diff / mag, 0.15) << "mean relative message difference";

  std::vector<float> q_exact, q_lattice;
  exact.infer(unary, L, q_exact);
  lattice.infer(unary, L, q_lattice);
  const std::vector<int> a = hard_labels(q_exact, L), b = hard_labels(q_lattice, L);
  int same = 0;
  for (size_t i = 0; i < a.size(); ++i) same += a[i] == b[i];
  EXPECT_GT(static_cast<double>(same) / static_cast<double>(a.size()), 0.95);
}

// Two regions of different colour; every fourth node's unary is flipped to the wrong label.
TEST(DenseCrf, SmoothnessCleansNoisyUnaries) {
  const int gw = 30, gh = 20, L = 2;
  std::vector<CrfNode> nodes = grid_nodes(gw, gh, 5, false);
  std::vector<float> unary(nodes.size() * L);
  std::vector<int> truth(nodes.size());
  int noisy_correct = 0;
  for (size_t i = 0; i < nodes.size(); ++i) {
    const int x = static_cast<int>(i) % gw;
    truth[i] = x >= gw / 2;
    if (truth[i]) nodes[i].r += 120.0f;
    const bool flipped = (i * 7919) % 4 == 0;
    const int want = flipped ? 1 - truth[i] : truth[i];
    noisy_correct += want == truth[i];
    for (int l = 0; l < L; ++l) unary[i * L + static_cast<size_t>(l)] = l == want ? 0.0f : 1.5f;
  }
  ASSERT_LT(noisy_correct, static_cast<int>(nodes.size() * 8 / 10));
  for (const CrfMethod method : {CrfMethod::kExact, CrfMethod::kPermutohedral}) {
    CrfParams params;
    params.method = method;
    DenseCrf crf;
    crf.set_nodes(nodes, params);
    std::vector<float> q;
    crf.infer(unary, L, q);
    const std::vector<int> labels = hard_labels(q, L);
    int correct = 0;
    for (size_t i = 0; i < labels.size(); ++i) correct += labels[i] == truth[i];
    EXPECT_GT(correct, static_cast<int>(nodes.size() * 98 / 100)) << "method " << static_cast<int>(method);
  }
}

// A 5x5 island mildly prefers label 1 inside a sea that is sure of label 0. With the island's
// colour equal to the sea's, the kernels pull it into the sea; with a strong colour edge the
// appearance kernel sees only the island itself and the island keeps its label.
TEST(DenseCrf, ColourEdgeKeepsLabelsApart) {
  const int gw = 30, gh = 20, L = 2;
  auto island = [&](size_t i) {
    const int x = static_cast<int>(i) % gw, y = static_cast<int>(i) / gw;
    return x >= 12 && x < 17 && y >= 8 && y < 13;
  };
  auto run = [&](bool colour_edge, CrfMethod method) {
    std::vector<CrfNode> nodes = grid_nodes(gw, gh, 9, false);
    std::vector<float> unary(nodes.size() * L);
    for (size_t i = 0; i < nodes.size(); ++i) {
      if (island(i) && colour_edge) {
        nodes[i].r += 150.0f;
        nodes[i].b -= 150.0f;
      }
      unary[i * L + 0] = island(i) ? 0.8f : 0.0f;
      unary[i * L + 1] = island(i) ? 0.0f : 3.0f;
    }
    CrfParams params;
    params.method = method;
    DenseCrf crf;
    crf.set_nodes(nodes, params);
    std::vector<float> q;
    crf.infer(unary, L, q);
    const std::vector<int> labels = hard_labels(q, L);
    int island_kept = 0, sea_kept = 0;
    for (size_t i = 0; i < labels.size(); ++i) (island(i) ? island_kept : sea_kept) += labels[i] == (island(i) ? 1 : 0);
    EXPECT_EQ(sea_kept, gw * gh - 25);
    return island_kept;
  };
  for (const CrfMethod method : {CrfMethod::kExact, CrfMethod::kPermutohedral}) {
    EXPECT_EQ(run(true, method), 25) << "method " << static_cast<int>(method) << ": the edge keeps the island";
    EXPECT_EQ(run(false, method), 0) << "method " << static_cast<int>(method) << ": without it the island is absorbed";
  }
}

TEST(DenseCrf, ZeroIterationsIsSoftmaxOfUnaries) {
  const std::vector<CrfNode> nodes = grid_nodes(4, 3, 1);
  const std::vector<float> unary = {0, 1, 2, 0, 0, 0, 5, 1, 1, 3, 2, 1, 0, 0, 9, 1, 2, 3,
                                    0, 1, 2, 0, 0, 0, 5, 1, 1, 3, 2, 1, 0, 0, 9, 1, 2, 3};
  CrfParams params;
  params.iterations = 0;
  DenseCrf crf;
  crf.set_nodes(nodes, params);
  std::vector<float> q;
  crf.infer(unary, 3, q);
  ASSERT_EQ(q.size(), unary.size());
  for (size_t i = 0; i < nodes.size(); ++i) {
    double z = 0;
    for (int l = 0; l < 3; ++l) z += std::exp(-unary[i * 3 + static_cast<size_t>(l)]);
    for (int l = 0; l < 3; ++l)
      EXPECT_NEAR(q[i * 3 + static_cast<size_t>(l)], std::exp(-unary[i * 3 + static_cast<size_t>(l)]) / z, 1e-6);
  }
}

TEST(DenseCrf, DenseAndTruncatedExactKernelsMatch) {
  // exact_cutoff = 0 keeps every pair; the default drops values below 1e-6.
  const std::vector<CrfNode> nodes = grid_nodes(24, 18, 2);
  std::vector<float> q(nodes.size() * 2);
  for (size_t i = 0; i < nodes.size(); ++i) q[2 * i] = 1.0f - (q[2 * i + 1] = (i % 3 == 0) ? 0.9f : 0.2f);
  CrfParams params;
  params.method = CrfMethod::kExact;
  DenseCrf truncated, dense;
  truncated.set_nodes(nodes, params);
  params.exact_cutoff = 0;
  dense.set_nodes(nodes, params);
  EXPECT_EQ(dense.exact_entries(), static_cast<int64_t>(nodes.size() * nodes.size()));
  EXPECT_LT(truncated.exact_entries(), dense.exact_entries());
  std::vector<float> a(q.size()), b(q.size());
  truncated.message(q, 2, a);
  dense.message(q, 2, b);
  for (size_t k = 0; k < q.size(); ++k) EXPECT_NEAR(a[k], b[k], 1e-4 * (1 + std::abs(b[k])));
}

TEST(DenseCrf, RejectsBadInput) {
  CrfParams params;
  params.sigma_colour = 0;
  DenseCrf crf;
  EXPECT_NE(test::error_of([&] { crf.set_nodes({}, params); }).find("sigma"), std::string::npos);
  params = {};
  const std::vector<CrfNode> nodes = grid_nodes(3, 3, 1);
  crf.set_nodes(nodes, params);
  std::vector<float> q;
  EXPECT_NE(test::error_of([&] { crf.infer(std::vector<float>(5), 2, q); }).find("unary"), std::string::npos);
  std::vector<CrfNode> bad = nodes;
  bad[4].depth_m = std::nanf("");
  params.method = CrfMethod::kExact;
  EXPECT_NE(test::error_of([&] { crf.set_nodes(bad, params); }).find("non-finite"), std::string::npos);
}

}  // namespace
}  // namespace cofusion::segmentation
