// The genetic algorithm and the NLopt globals on functions with known minima, and the
// reproducibility guarantees (bit for bit with a fixed seed, also in parallel threads).
#include <gtest/gtest.h>

#include <atomic>
#include <cmath>
#include <cstring>
#include <numbers>
#include <thread>
#include <vector>

#include "momentum/core/random.hpp"
#include "momentum/friction_fit/genetic.hpp"

namespace friction_fit = momentum::friction_fit;

namespace {

// Shifted, badly scaled quadratic: minimum 0 at (3e4, 0.02, 7), scales like sigma0 / w_s / tau.
double scaled_quadratic(std::span<const double> x) {
  const double a = (x[0] - 3e4) / 1e4, b = (x[1] - 0.02) / 0.01, c = x[2] - 7.0;
  return a * a + b * b + c * c;
}
friction_fit::Bounds scaled_bounds() { return {{0.0, 0.0, 0.0}, {1e5, 0.1, 10.0}}; }

// Rastrigin in 2-D: many local minima, global minimum 0 at the origin.
double rastrigin(std::span<const double> x) {
  double f = 10.0 * static_cast<double>(x.size());
  for (double v : x) f += v * v - 10.0 * std::cos(2 * std::numbers::pi * v);
  return f;
}

bool same_bits(double a, double b) { return std::memcmp(&a, &b, sizeof a) == 0; }

}  // namespace

TEST(Genetic, FindsMinimumOfScaledQuadratic) {
  friction_fit::GeneticOptions o;
  o.population = 60;
  o.generations = 120;
  o.seed = 7;
  const auto s = friction_fit::minimize_genetic(scaled_quadratic, scaled_bounds(), o);
  EXPECT_LT(s.cost, 1e-4);
  EXPECT_NEAR(s.best[0], 3e4, 1e2);
  EXPECT_NEAR(s.best[1], 0.02, 1e-4);
  EXPECT_NEAR(s.best[2], 7.0, 1e-2);
  EXPECT_EQ(s.cost, scaled_quadratic(s.best));
}

TEST(Genetic, EscapesLocalMinimaOfRastrigin) {
  friction_fit::GeneticOptions o;
  o.population = 80;
  o.generations = 150;
  o.restarts = 2;
  o.seed = 3;
  const friction_fit::Bounds box{{-5.12, -5.12}, {5.12, 5.12}};
  const auto s = friction_fit::minimize_genetic(rastrigin, box, o);
  // The nearest local minima are at distance 1 with cost ~1.
  EXPECT_LT(s.cost, 1e-3);
  EXPECT_NEAR(s.best[0], 0.0, 1e-2);
  EXPECT_NEAR(s.best[1], 0.0, 1e-2);
  EXPECT_EQ(s.runs, 2);
  ASSERT_EQ(s.run_costs.size(), 2u);
  EXPECT_EQ(s.cost, std::min(s.run_costs[0], s.run_costs[1]));
}

TEST(Genetic, EvaluationCountAndElitism) {
  friction_fit::GeneticOptions o;
  o.population = 30;
  o.generations = 25;
  o.elite = 3;
  o.restarts = 2;
  std::vector<double> best_per_generation;
  o.on_generation = [&](const friction_fit::SearchProgress& p) { best_per_generation.push_back(p.best_cost); };
  std::uint64_t calls = 0;
  bool inside = true;
  const auto box = scaled_bounds();
  auto counted = [&](std::span<const double> x) {
    ++calls;
    inside = inside && box.contains(x);
    return scaled_quadratic(x);
  };
  const auto s = friction_fit::minimize_genetic(counted, box, o);
  // Each run: the initial population, then population - elite new individuals a generation.
  EXPECT_EQ(s.evaluations, 2u * (30u + 24u * 27u));
  EXPECT_EQ(calls, s.evaluations);
  EXPECT_EQ(s.generations, 50);
  EXPECT_TRUE(inside) << "an individual left the bounds";
  ASSERT_EQ(best_per_generation.size(), 50u);
  for (std::size_t g = 1; g < best_per_generation.size(); ++g)
    EXPECT_LE(best_per_generation[g], best_per_generation[g - 1]) << "generation " << g;
}

TEST(Genetic, StopsWhenStalled) {
  friction_fit::GeneticOptions o;
  o.population = 10;
  o.generations = 1000;
  o.stall_generations = 5;
  // A constant cost never improves: the first generation sets the reference, five more stall.
  const auto s = friction_fit::minimize_genetic([](std::span<const double>) { return 1.0; },
                                       friction_fit::Bounds{{0.0}, {1.0}}, o);
  EXPECT_EQ(s.generations, 6);
  EXPECT_NE(s.message.find("stalled"), std::string::npos) << s.message;
}

TEST(Genetic, NanCostsAreWorst) {
  friction_fit::GeneticOptions o;
  o.population = 20;
  o.generations = 30;
  // NaN on half of the box: the search must settle in the other half.
  auto cost = [](std::span<const double> x) {
    return x[0] < 0.5 ? std::nan("") : (x[0] - 0.7) * (x[0] - 0.7);
  };
  const auto s = friction_fit::minimize_genetic(cost, friction_fit::Bounds{{0.0}, {1.0}}, o);
  EXPECT_NEAR(s.best[0], 0.7, 1e-3);
}

TEST(Genetic, ReproducibleBitForBit) {
  friction_fit::GeneticOptions o;
  o.population = 40;
  o.generations = 40;
  o.seed = 12345;
  const auto a = friction_fit::minimize_genetic(rastrigin, friction_fit::Bounds{{-5.12, -5.12}, {5.12, 5.12}}, o);
  const auto b = friction_fit::minimize_genetic(rastrigin, friction_fit::Bounds{{-5.12, -5.12}, {5.12, 5.12}}, o);
  ASSERT_EQ(a.best.size(), b.best.size());
  for (std::size_t i = 0; i < a.best.size(); ++i) EXPECT_TRUE(same_bits(a.best[i], b.best[i]));
  EXPECT_TRUE(same_bits(a.cost, b.cost));
  EXPECT_EQ(a.evaluations, b.evaluations);
  o.seed = 12346;
  const auto c = friction_fit::minimize_genetic(rastrigin, friction_fit::Bounds{{-5.12, -5.12}, {5.12, 5.12}}, o);
  EXPECT_FALSE(same_bits(a.best[0], c.best[0]) && same_bits(a.best[1], c.best[1]));
}

TEST(Genetic, ReproducibleInParallelThreads) {
  const friction_fit::Bounds box{{-5.12, -5.12, -5.12}, {5.12, 5.12, 5.12}};
  constexpr int kProblems = 4;
  auto solve = [&](int k) {
    friction_fit::GeneticOptions o;
    o.population = 30;
    o.generations = 30;
    o.seed = momentum::core::derive_seed(99, static_cast<std::uint64_t>(k));
    return friction_fit::minimize_genetic(rastrigin, box, o);
  };
  std::vector<friction_fit::GlobalSummary> sequential, parallel(kProblems);
  for (int k = 0; k < kProblems; ++k) sequential.push_back(solve(k));
  std::vector<std::thread> threads;
  for (int k = kProblems - 1; k >= 0; --k) threads.emplace_back([&, k] { parallel[k] = solve(k); });
  for (auto& t : threads) t.join();
  for (int k = 0; k < kProblems; ++k) {
    EXPECT_TRUE(same_bits(sequential[k].cost, parallel[k].cost)) << "problem " << k;
    for (std::size_t i = 0; i < 3; ++i)
      EXPECT_TRUE(same_bits(sequential[k].best[i], parallel[k].best[i])) << "problem " << k;
  }
}

TEST(Genetic, RejectsInvalidOptions) {
  friction_fit::GeneticOptions o;
  std::string why;
  EXPECT_TRUE(o.IsValid(&why));
  o.population = 3;
  EXPECT_FALSE(o.IsValid(&why));
  o = {};
  o.elite = o.population;
  EXPECT_FALSE(o.IsValid(&why));
  o = {};
  o.crossover = 1.5;
  EXPECT_FALSE(o.IsValid(&why));
  EXPECT_THROW(friction_fit::minimize_genetic(rastrigin, friction_fit::Bounds{{0.0}, {1.0}}, o), std::invalid_argument);
  EXPECT_THROW(friction_fit::minimize_genetic(rastrigin, friction_fit::Bounds{{1.0}, {1.0}}, {}), std::invalid_argument);
  EXPECT_THROW(friction_fit::minimize_genetic(rastrigin, friction_fit::Bounds{{0.0}, {INFINITY}}, {}), std::invalid_argument);
}

TEST(Genetic, PaperDefaults) {
  const friction_fit::GeneticOptions o;
  EXPECT_EQ(o.population, 200);
  EXPECT_EQ(o.generations, 300);
  EXPECT_EQ(o.crossover, 0.8);
  EXPECT_EQ(o.mutation, 0.2);
}

class NloptGlobal : public ::testing::TestWithParam<friction_fit::GlobalMethod> {};

TEST_P(NloptGlobal, FindsMinimumAndIsReproducible) {
  friction_fit::GlobalOptions o;
  o.method = GetParam();
  o.genetic.population = 40;
  o.genetic.seed = 5;
  o.max_evaluations = 20000;
  const auto a = friction_fit::minimize_global(scaled_quadratic, scaled_bounds(), o);
  EXPECT_LT(a.cost, 1e-3) << friction_fit::method_name(o.method) << ": " << a.message;
  EXPECT_LE(a.evaluations, 20000u + 100u);  // some methods overshoot the budget slightly
  EXPECT_EQ(a.cost, scaled_quadratic(a.best));
  const auto b = friction_fit::minimize_global(scaled_quadratic, scaled_bounds(), o);
  EXPECT_TRUE(same_bits(a.cost, b.cost)) << friction_fit::method_name(o.method);
  EXPECT_EQ(a.evaluations, b.evaluations);
}

INSTANTIATE_TEST_SUITE_P(Methods, NloptGlobal,
                         ::testing::Values(friction_fit::GlobalMethod::crs2, friction_fit::GlobalMethod::isres,
                                           friction_fit::GlobalMethod::mlsl, friction_fit::GlobalMethod::esch),
                         [](const auto& info) { return std::string(friction_fit::method_name(info.param)); });

TEST(GlobalMethod, NamesRoundTrip) {
  for (auto m : {friction_fit::GlobalMethod::ga, friction_fit::GlobalMethod::crs2, friction_fit::GlobalMethod::isres,
                 friction_fit::GlobalMethod::mlsl, friction_fit::GlobalMethod::esch}) {
    friction_fit::GlobalMethod back{};
    ASSERT_TRUE(friction_fit::parse_method(friction_fit::method_name(m), &back));
    EXPECT_EQ(back, m);
  }
  friction_fit::GlobalMethod m{};
  EXPECT_FALSE(friction_fit::parse_method("pso", &m));
}
