// The solver and the Laplace evidence against closed forms (docs/method.md §8.3) and
// dense brute-force computations.
#include "solver/sparse_solver.h"

#include <cmath>
#include <cstdlib>
#include <functional>
#include <string>

#include <gtest/gtest.h>
#include <Eigen/Dense>

#include "calib/hyperbolic_camera.h"
#include "slam/factors.h"
#include "slam/geometric_slam.h"
#include "tests/slam/synthetic_scene.h"

namespace oslam {
namespace {

const double kLog2Pi = std::log(2.0 * kPi);

// A scalar "range" reading x = r with std sigma is a 1-D prior on x.
void AddReading(FactorGraph* graph, int key, double r, double sigma) {
  graph->Emplace<PriorFactor>(key, Eigen::VectorXd::Constant(1, r),
                              Eigen::MatrixXd::Constant(1, 1, sigma * sigma), "reading");
}

struct ToyRow {
  double r2, sigma_r, sigma_o, res1, res2, log_e1, log_e2, p_j1;
};

// docs/method.md §8.3 unit-test vectors (r1 = 1 m; log-evidences include log 0.5).
TEST(EvidenceTest, ToyExampleOfSpec83) {
  const ToyRow rows[] = {
      {1.00, 0.1, 5, 0.039992, 0.079968, -2.204547, -5.790284, 0.973031},
      {1.20, 0.1, 5, 2.048390, 0.097561, -3.208746, -5.799080, 0.930237},
      {0.70, 0.5, 5, 0.208756, 0.059010, -3.900760, -5.789355, 0.868595},
      {1.05, 0.01, 5, 12.542025, 0.084100, -6.152879, -5.791954, 0.410736},
  };
  for (const auto linear_solver :
       {LinearSolverType::kSparseCholesky, LinearSolverType::kSparseQR}) {
    SolverOptions options;
    options.linear_solver = linear_solver;
    SparseSolver solver(options);
    for (const ToyRow& row : rows) {
      const double r1 = 1.0;
      // J1: one obstacle; rows x = 0 (sigma_o), x = r1, x = r2 (sigma_r).
      FactorGraph j1;
      const int x = j1.AddVariable(Eigen::VectorXd::Zero(1));
      AddReading(&j1, x, 0.0, row.sigma_o);
      AddReading(&j1, x, r1, row.sigma_r);
      AddReading(&j1, x, row.r2, row.sigma_r);
      const SolveResult a = solver.Solve(&j1);
      ASSERT_TRUE(a.summary.IsUsable()) << a.summary.message;
      ASSERT_TRUE(a.evidence.valid);
      // J2: two obstacles, each with its prior and one reading.
      FactorGraph j2;
      const int x1 = j2.AddVariable(Eigen::VectorXd::Zero(1));
      const int x2 = j2.AddVariable(Eigen::VectorXd::Zero(1));
      AddReading(&j2, x1, 0.0, row.sigma_o);
      AddReading(&j2, x2, 0.0, row.sigma_o);
      AddReading(&j2, x1, r1, row.sigma_r);
      AddReading(&j2, x2, row.r2, row.sigma_r);
      const SolveResult b = solver.Solve(&j2);
      ASSERT_TRUE(b.evidence.valid);

      EXPECT_NEAR(a.evidence.squared_residual, row.res1, 1e-6);
      EXPECT_NEAR(b.evidence.squared_residual, row.res2, 1e-6);
      const double log_e1 = a.evidence.log_evidence + std::log(0.5);
      const double log_e2 = b.evidence.log_evidence + std::log(0.5);
      EXPECT_NEAR(log_e1, row.log_e1, 1e-6);
      EXPECT_NEAR(log_e2, row.log_e2, 1e-6);
      EXPECT_NEAR(1.0 / (1.0 + std::exp(log_e2 - log_e1)), row.p_j1, 1e-6);

      // And the closed forms themselves, to more digits.
      const double so2 = row.sigma_o * row.sigma_o, sr2 = row.sigma_r * row.sigma_r;
      const double closed1 = std::log(0.5 / (2 * kPi * std::sqrt(2 * so2 * sr2 + sr2 * sr2))) -
                             0.5 * a.evidence.squared_residual;
      const double closed2 =
          std::log(0.5 / (2 * kPi * (so2 + sr2))) - 0.5 * b.evidence.squared_residual;
      EXPECT_NEAR(log_e1, closed1, 1e-12);
      EXPECT_NEAR(log_e2, closed2, 1e-12);
      EXPECT_NEAR(j1.values().Get(x)[0], so2 * (r1 + row.r2) / (2 * so2 + sr2), 1e-9);
      // Posterior variance Sigma1 of J1.
      std::vector<Eigen::MatrixXd> blocks;
      ASSERT_TRUE(solver.Solve(&j1).evidence.valid);
      ASSERT_TRUE(solver.MarginalCovariances({{x}}, &blocks));
      EXPECT_NEAR(blocks[0](0, 0), so2 * sr2 / (2 * so2 + sr2), 1e-12);
    }
  }
}

TEST(EvidenceTest, WindowWhereOneObstacleWinsMatchesSpec) {
  // sigma_r = 0.1, sigma_o = 5: J1 wins for r2 in [0.622, 1.379].
  SparseSolver solver;
  auto log_ratio = [&](double r2) {
    FactorGraph j1, j2;
    const int x = j1.AddVariable(Eigen::VectorXd::Zero(1));
    AddReading(&j1, x, 0.0, 5);
    AddReading(&j1, x, 1.0, 0.1);
    AddReading(&j1, x, r2, 0.1);
    const double e1 = solver.Solve(&j1).evidence.log_evidence;
    const int x1 = j2.AddVariable(Eigen::VectorXd::Zero(1));
    const int x2 = j2.AddVariable(Eigen::VectorXd::Zero(1));
    AddReading(&j2, x1, 0.0, 5);
    AddReading(&j2, x2, 0.0, 5);
    AddReading(&j2, x1, 1.0, 0.1);
    AddReading(&j2, x2, r2, 0.1);
    return e1 - solver.Solve(&j2).evidence.log_evidence;
  };
  EXPECT_GT(log_ratio(0.63), 0);
  EXPECT_LT(log_ratio(0.61), 0);
  EXPECT_GT(log_ratio(1.37), 0);
  EXPECT_LT(log_ratio(1.39), 0);
}

// Dense reference: stack every factor's whitened rows at the solution and
// compute ||r||^2, log det(A'A) (by Householder QR) and the covariance.
struct DenseReference {
  double squared_residual, log_det_information, log_evidence;
  Eigen::MatrixXd covariance;
  std::vector<int> offset;  // per key, -1 when fixed
};

DenseReference DenseEvidence(const FactorGraph& graph) {
  DenseReference out;
  int n = 0, m = 0;
  for (int key = 0; key < graph.num_variables(); ++key) {
    out.offset.push_back(graph.IsFixed(key) ? -1 : n);
    if (!graph.IsFixed(key)) n += graph.values().Dim(key);
  }
  for (const auto& f : graph.factors()) m += f->Dimension();
  Eigen::MatrixXd a = Eigen::MatrixXd::Zero(m, n);
  Eigen::VectorXd b(m);
  double log_det_noise = 0;
  int row = 0;
  for (const auto& f : graph.factors()) {
    int total = 0;
    for (int key : f->keys()) total += graph.values().Dim(key);
    Eigen::VectorXd e(f->Dimension());
    Eigen::MatrixXd j(f->Dimension(), total);
    EXPECT_TRUE(f->Linearize(graph.values(), e, &j));
    int column = 0;
    for (int key : f->keys()) {
      const int d = graph.values().Dim(key);
      if (out.offset[key] >= 0)
        a.block(row, out.offset[key], f->Dimension(), d) += j.middleCols(column, d);
      column += d;
    }
    b.segment(row, f->Dimension()) = -e;
    log_det_noise += f->LogDetCovariance();
    row += f->Dimension();
  }
  const Eigen::HouseholderQR<Eigen::MatrixXd> qr(a);
  const Eigen::MatrixXd r = qr.matrixQR().topRows(n).triangularView<Eigen::Upper>();
  out.log_det_information = 2.0 * r.diagonal().cwiseAbs().array().log().sum();
  const Eigen::VectorXd delta = qr.solve(b);
  out.squared_residual = (a * delta - b).squaredNorm();
  out.log_evidence = -0.5 * out.squared_residual - 0.5 * log_det_noise -
                     0.5 * out.log_det_information + 0.5 * (n - m) * kLog2Pi;
  out.covariance = (a.transpose() * a).inverse();
  return out;
}

// The solver's covariance blocks (one per group of keys) against the same
// blocks of the dense inverse, relative tolerance.
void ExpectBlocksOfDenseCovariance(const FactorGraph& graph, const DenseReference& dense,
                                   const std::vector<std::vector<int>>& groups,
                                   const std::vector<Eigen::MatrixXd>& blocks, double tolerance) {
  ASSERT_EQ(blocks.size(), groups.size());
  for (size_t g = 0; g < groups.size(); ++g) {
    std::vector<int> index;
    for (int key : groups[g])
      for (int r = 0; r < graph.values().Dim(key); ++r) index.push_back(dense.offset[key] + r);
    Eigen::MatrixXd expected(index.size(), index.size());
    for (size_t r = 0; r < index.size(); ++r)
      for (size_t c = 0; c < index.size(); ++c)
        expected(r, c) = dense.covariance(index[r], index[c]);
    EXPECT_LT((blocks[g] - expected).cwiseAbs().maxCoeff(), tolerance * (1 + expected.norm()))
        << "group " << g;
  }
}

// A small noisy SLAM graph (few poses, two objects) for dense comparisons;
// skip_every > 0 leaves out every skip_every-th detection.
FactorGraph SmallSlamGraph(const CameraModel& camera, unsigned seed, int num_poses,
                           int num_objects = 3, int skip_every = 0) {
  testing::SyntheticSceneOptions options;
  options.num_poses = num_poses;
  options.num_objects = num_objects;
  options.loop_length_m = 2.0;
  options.loop_width_m = 1.0;
  options.pixel_std_px = 10.0;
  options.odometry_noise = true;
  options.seed = seed;
  const testing::SyntheticScene scene = testing::MakeSyntheticScene(camera, options);
  FactorGraph graph;
  const auto& p = scene.problem;
  const std::vector<Pose2> poses = ComposeOdometry(p.first_pose, p.increments);
  std::vector<int> pose_keys;
  for (size_t i = 0; i < poses.size(); ++i)
    pose_keys.push_back(graph.AddPose(poses[i].x, poses[i].y, poses[i].theta, i == 0));
  std::map<int, std::pair<int, int>> object_keys;
  for (const auto& [id, class_index] : p.object_class) {
    const ClassPrior& prior = p.classes[class_index];
    const auto& truth = scene.true_objects[id];
    const int base = graph.AddVariable(truth.base_world + Eigen::Vector3d(0.1, -0.1, 0.05));
    const int size = graph.AddVariable(prior.size_mean_m);
    graph.Add(MakeLocationPrior(base, prior.location_mean_m, prior.location_std_m));
    graph.Add(MakeSizePrior(size, prior.size_mean_m, prior.size_std_m));
    object_keys[id] = {base, size};
  }
  for (size_t i = 1; i < poses.size(); ++i)
    graph.Emplace<OdometryFactor>(pose_keys[i - 1], pose_keys[i], p.increments[i],
                                  MotionNoiseOptions());
  for (size_t k = 0; k < p.observations.size(); ++k) {
    if (skip_every > 0 && k % skip_every == 0) continue;
    const auto& o = p.observations[k];
    graph.Emplace<BoundingSliceFactor>(&camera, pose_keys[o.frame], object_keys[o.object_id].first,
                                       object_keys[o.object_id].second, o.slice, 10.0);
  }
  return graph;
}

TEST(EvidenceTest, EqualsDenseBruteForceOnSmallSlamProblems) {
  const HyperbolicCamera camera = HyperbolicCamera::Preset("lpa");
  for (unsigned seed : {1u, 2u, 3u}) {
    for (const auto linear_solver :
         {LinearSolverType::kSparseCholesky, LinearSolverType::kSparseQR}) {
      FactorGraph graph = SmallSlamGraph(camera, seed, 25);
      SolverOptions options;
      options.linear_solver = linear_solver;
      options.apply_final_step = false;  // compare at the evidence's linearisation point
      SparseSolver solver(options);
      const SolveResult result = solver.Solve(&graph);
      ASSERT_EQ(result.summary.termination, TerminationType::kConverged) << result.summary.message;
      ASSERT_TRUE(result.evidence.valid);
      const DenseReference dense = DenseEvidence(graph);
      EXPECT_NEAR(result.evidence.squared_residual, dense.squared_residual, 1e-8);
      EXPECT_NEAR(result.evidence.log_det_information, dense.log_det_information, 1e-7);
      EXPECT_NEAR(result.evidence.log_evidence, dense.log_evidence, 1e-7);
      // Covariance of every free pose and of each object's (base, size).
      std::vector<std::vector<int>> groups;
      for (int key = 0; key < graph.num_variables(); ++key)
        if (!graph.IsFixed(key)) groups.push_back({key});
      groups.push_back({graph.num_variables() - 2, graph.num_variables() - 1});
      std::vector<Eigen::MatrixXd> blocks;
      ASSERT_TRUE(solver.MarginalCovariances(groups, &blocks));
      ExpectBlocksOfDenseCovariance(graph, dense, groups, blocks, 1e-9);
    }
  }
}

// Big enough for CHOLMOD's supernodal LL' factor (many objects seen from
// every pose), where object covariances come from a forward solve only
// (Y' Y with Y = L^-1 E): they must equal the dense inverse too.
TEST(SolverTest, ObjectCovariancesOfASupernodalFactorEqualTheDenseInverse) {
  const HyperbolicCamera camera = HyperbolicCamera::Preset("lpa");
  FactorGraph graph = SmallSlamGraph(camera, 4, 120, 14);
  SolverOptions options;
  options.apply_final_step = false;
  SparseSolver solver(options);
  const SolveResult result = solver.Solve(&graph);
  ASSERT_TRUE(result.summary.IsUsable()) << result.summary.message;
  const DenseReference dense = DenseEvidence(graph);
  EXPECT_NEAR(result.evidence.log_det_information, dense.log_det_information,
              1e-7 * std::abs(dense.log_det_information));
  std::vector<std::vector<int>> groups;
  for (int key = 120; key + 1 < graph.num_variables(); key += 2) groups.push_back({key, key + 1});
  groups.push_back({5, 60});  // two poses far apart: an off-diagonal block too
  ASSERT_GE(groups.size(), 14u);
  std::vector<Eigen::MatrixXd> blocks;
  ASSERT_TRUE(solver.MarginalCovariances(groups, &blocks));
  ExpectBlocksOfDenseCovariance(graph, dense, groups, blocks, 1e-8);
}

// The square-root columns of a small (simplicial LDL') and of the same
// supernodal factor: Y_a' Y_b is the
// (a, b) block of the inverse (MarginalCovariances, checked against the
// dense inverse above), within a group and across two.
TEST(SolverTest, CovarianceRootsGiveTheBlocksOfTheDenseInverse) {
  const HyperbolicCamera camera = HyperbolicCamera::Preset("lpa");
  for (const int poses : {25, 120}) {  // a simplicial LDL' and a supernodal LL' factor
    SCOPED_TRACE(poses);
    FactorGraph graph =
        poses == 120 ? SmallSlamGraph(camera, 4, 120, 14) : SmallSlamGraph(camera, 1, poses);
    SolverOptions options;
    options.apply_final_step = false;
    SparseSolver solver(options);
    ASSERT_TRUE(solver.Solve(&graph).summary.IsUsable());
    const int last = graph.num_variables() - 1;
    const std::vector<std::vector<int>> groups = {{last - 1, last}, {5}, {20, last - 2}};
    std::vector<CovarianceRoot> roots;
    ASSERT_TRUE(solver.CovarianceRoots(groups, &roots));
    ASSERT_EQ(roots.size(), groups.size());
    // Each root is kept on the rows where it is non-zero, ascending, and
    // holds the group's own rows; not every row of the factor.
    size_t kept_rows = 0, all_rows = 0, n = 0;
    for (int key = 0; key < graph.num_variables(); ++key)
      n += static_cast<size_t>(graph.values().Dim(key));
    for (size_t g = 0; g < groups.size(); ++g) {
      const CovarianceRoot& root = roots[g];
      ASSERT_EQ(root.values.rows(), static_cast<Eigen::Index>(root.rows.size()));
      int width = 0;
      for (int key : groups[g]) width += graph.values().Dim(key);
      ASSERT_EQ(root.values.cols(), width);
      EXPECT_TRUE(std::is_sorted(root.rows.begin(), root.rows.end()));
      EXPECT_EQ(std::adjacent_find(root.rows.begin(), root.rows.end()), root.rows.end());
      kept_rows += root.rows.size();
      all_rows += n;
    }
    std::printf("%d poses: roots kept on %zu of %zu rows\n", poses, kept_rows, all_rows);
    EXPECT_LT(kept_rows, all_rows);
    for (size_t a = 0; a < groups.size(); ++a)
      for (size_t b = a; b < groups.size(); ++b) {
        std::vector<Eigen::MatrixXd> block;  // the joint block, its (a, b) part compared
        std::vector<int> both = groups[a];
        both.insert(both.end(), groups[b].begin(), groups[b].end());
        ASSERT_TRUE(solver.MarginalCovariances({both}, &block));
        const Eigen::MatrixXd product = RootProduct(roots[a], roots[b]);
        const Eigen::MatrixXd expected =
            block[0].block(0, block[0].cols() - product.cols(), product.rows(), product.cols());
        EXPECT_LT((product - expected).cwiseAbs().maxCoeff(), 1e-8 * expected.cwiseAbs().maxCoeff())
            << "groups " << a << ", " << b;
      }
  }
}

// Every fill-reducing ordering (and the QR path) must give the same
// iterates, evidence and covariances: the permutation is bookkeeping only.
TEST(SolverTest, EveryOrderingGivesTheSameSolutionEvidenceAndCovariance) {
  const HyperbolicCamera camera = HyperbolicCamera::Preset("lpa");
  for (unsigned seed : {1u, 4u}) {
    SolveResult reference;
    std::vector<Eigen::MatrixXd> reference_blocks;
    Eigen::VectorXd reference_values;
    bool have_reference = false;
    for (const OrderingType ordering : {OrderingType::kAutomatic, OrderingType::kAmd,
                                        OrderingType::kHighDegreeLast, OrderingType::kMetis}) {
      FactorGraph graph = SmallSlamGraph(camera, seed, 40);
      SolverOptions options;
      options.ordering = ordering;
      SparseSolver solver(options);
      const SolveResult result = solver.Solve(&graph);
      ASSERT_EQ(result.summary.termination, TerminationType::kConverged) << result.summary.message;
      ASSERT_TRUE(result.evidence.valid);
      if (ordering != OrderingType::kAutomatic) {
        EXPECT_EQ(result.summary.ordering, ordering);
      }
      std::vector<std::vector<int>> groups;
      for (int key = 0; key < graph.num_variables(); ++key)
        if (!graph.IsFixed(key)) groups.push_back({key});
      std::vector<Eigen::MatrixXd> blocks;
      ASSERT_TRUE(solver.MarginalCovariances(groups, &blocks));
      Eigen::VectorXd values(3 * graph.num_variables());
      values.setZero();
      for (int key = 0; key < graph.num_variables(); ++key)
        values.segment(3 * key, graph.values().Dim(key)) = graph.values().Get(key);
      if (!have_reference) {
        reference = result;
        reference_blocks = blocks;
        reference_values = values;
        have_reference = true;
        continue;
      }
      EXPECT_EQ(result.summary.iterations, reference.summary.iterations);
      EXPECT_NEAR(result.summary.final_cost, reference.summary.final_cost,
                  1e-9 * reference.summary.final_cost);
      EXPECT_NEAR(result.evidence.log_evidence, reference.evidence.log_evidence, 1e-7);
      EXPECT_NEAR(result.evidence.log_det_information, reference.evidence.log_det_information,
                  1e-7);
      EXPECT_LT((values - reference_values).cwiseAbs().maxCoeff(), 1e-8);
      for (size_t g = 0; g < blocks.size(); ++g)
        EXPECT_LT((blocks[g] - reference_blocks[g]).cwiseAbs().maxCoeff(),
                  1e-9 * (1 + reference_blocks[g].norm()));
    }
    // And the dense brute force at the final linearisation point.
    FactorGraph graph = SmallSlamGraph(camera, seed, 40);
    SolverOptions options;
    options.ordering = OrderingType::kHighDegreeLast;
    options.apply_final_step = false;
    SparseSolver solver(options);
    const SolveResult result = solver.Solve(&graph);
    ASSERT_TRUE(result.evidence.valid);
    const DenseReference dense = DenseEvidence(graph);
    EXPECT_NEAR(result.evidence.log_evidence, dense.log_evidence, 1e-7);
  }
}

// The solver derives L's elimination tree and column counts from the block
// pattern instead of running cholmod_analyze on the scalar matrix; with
// OSLAM_SOLVER_CHECK_ANALYSIS it compares every analysis with CHOLMOD's
// (supernodal and simplicial factors, every ordering).
TEST(SolverTest, BlockSymbolicAnalysisEqualsCholmodsAnalysis) {
  const HyperbolicCamera camera = HyperbolicCamera::Preset("lpa");
  ASSERT_EQ(setenv("OSLAM_SOLVER_CHECK_ANALYSIS", "1", 1), 0);
  ::testing::internal::CaptureStderr();
  int solves = 0;
  for (const OrderingType ordering :
       {OrderingType::kAmd, OrderingType::kHighDegreeLast, OrderingType::kMetis}) {
    SolverOptions options;
    options.ordering = ordering;
    options.max_iterations = 1;
    FactorGraph large = SmallSlamGraph(camera, 4, 120, 14);  // supernodal
    FactorGraph small = SmallSlamGraph(camera, 1, 40);       // simplicial
    for (FactorGraph* graph : {&large, &small}) {
      SparseSolver solver(options);
      EXPECT_TRUE(solver.Solve(graph).summary.IsUsable());
      ++solves;
    }
  }
  const std::string report = ::testing::internal::GetCapturedStderr();
  unsetenv("OSLAM_SOLVER_CHECK_ANALYSIS");
  size_t same = 0;
  for (size_t at = report.find("analysis check: same"); at != std::string::npos;
       at = report.find("analysis check: same", at + 1))
    ++same;
  EXPECT_EQ(same, static_cast<size_t>(solves)) << report;
  EXPECT_EQ(report.find("DIFFERENT"), std::string::npos) << report;
  EXPECT_NE(report.find("super 1"), std::string::npos) << "no supernodal case: " << report;
  EXPECT_NE(report.find("super 0"), std::string::npos) << "no simplicial case: " << report;
}

TEST(SolverTest, ReportsProblemsInTheSummaryInsteadOfThrowing) {
  SparseSolver solver;
  FactorGraph empty;
  EXPECT_EQ(solver.Solve(&empty).summary.termination, TerminationType::kFailure);

  FactorGraph unconstrained;
  const int x = unconstrained.AddVariable(Eigen::VectorXd::Zero(1));
  unconstrained.AddVariable(Eigen::VectorXd::Zero(2));  // touched by no factor
  AddReading(&unconstrained, x, 1.0, 1.0);
  const SolveResult r = solver.Solve(&unconstrained);
  EXPECT_EQ(r.summary.termination, TerminationType::kFailure);
  EXPECT_NE(r.summary.message.find("no factor"), std::string::npos);

  SolverOptions bad;
  bad.initial_damping = -1;
  std::string why;
  EXPECT_FALSE(bad.Validate(&why));
  SparseSolver bad_solver(bad);
  FactorGraph one;
  AddReading(&one, one.AddVariable(Eigen::VectorXd::Zero(1)), 1.0, 1.0);
  const SolveResult invalid = bad_solver.Solve(&one);
  EXPECT_EQ(invalid.summary.termination, TerminationType::kFailure);
  EXPECT_NE(invalid.summary.message.find("initial_damping"), std::string::npos);
  SolverOptions bad_threads;
  bad_threads.threads = -1;
  EXPECT_FALSE(bad_threads.Validate(&why));
  EXPECT_NE(why.find("threads"), std::string::npos);

  // The block bookkeeping holds variables of up to 255 entries.
  FactorGraph wide;
  const int big = wide.AddVariable(Eigen::VectorXd::Zero(256));
  wide.Add(std::make_unique<PriorFactor>(big, Eigen::VectorXd::Ones(256),
                                         Eigen::MatrixXd::Identity(256, 256)));
  const SolveResult too_wide = solver.Solve(&wide);
  EXPECT_EQ(too_wide.summary.termination, TerminationType::kFailure);
  EXPECT_NE(too_wide.summary.message.find("more than 255 entries"), std::string::npos);
}

// A failed solve leaves nothing of the solve before it: covariances and
// samples are refused until a solve succeeds again (then they are its own).
TEST(SolverTest, AFailedSolveLeavesNoCovariancesOfTheSolveBefore) {
  SparseSolver solver;
  FactorGraph good;
  const int x = good.AddVariable(Eigen::VectorXd::Zero(1));
  AddReading(&good, x, 1.0, 0.5);
  AddReading(&good, x, 2.0, 0.5);
  ASSERT_TRUE(solver.Solve(&good).summary.IsUsable());
  std::vector<Eigen::MatrixXd> blocks;
  ASSERT_TRUE(solver.MarginalCovariances({{x}}, &blocks));
  EXPECT_NEAR(blocks[0](0, 0), 0.125, 1e-12);  // 1 / (2 / 0.25)

  FactorGraph unconstrained;  // fails in the set-up, before any factorisation
  const int y = unconstrained.AddVariable(Eigen::VectorXd::Zero(1));
  unconstrained.AddVariable(Eigen::VectorXd::Zero(2));
  AddReading(&unconstrained, y, 1.0, 1.0);
  FactorGraph bad_start;  // fails at the first evaluation
  const int z = bad_start.AddVariable(Eigen::VectorXd::Constant(1, std::nan("")));
  AddReading(&bad_start, z, 1.0, 1.0);
  SolverOptions invalid;
  invalid.initial_damping = -1;
  const std::vector<std::function<SolveResult()>> failures = {
      [&] { return solver.Solve(nullptr); }, [&] { return solver.Solve(&unconstrained); },
      [&] { return solver.Solve(&bad_start); },
      [&] {
        const SolverOptions kept = solver.options();
        solver.set_options(invalid);
        const SolveResult result = solver.Solve(&good);
        solver.set_options(kept);
        return result;
      }};
  for (size_t k = 0; k < failures.size(); ++k) {
    ASSERT_TRUE(solver.Solve(&good).summary.IsUsable());
    ASSERT_TRUE(solver.MarginalCovariances({{x}}, &blocks));
    EXPECT_EQ(failures[k]().summary.termination, TerminationType::kFailure) << k;
    std::string why;
    EXPECT_FALSE(solver.MarginalCovariances({{x}}, &blocks, &why)) << k;
    EXPECT_NE(why.find("no valid final factorisation"), std::string::npos) << k << ": " << why;
    std::vector<Eigen::MatrixXd> samples;
    EXPECT_FALSE(solver.CovarianceSamples({{x}}, 4, 1, &samples)) << k;
  }
  ASSERT_TRUE(solver.Solve(&good).summary.IsUsable());
  ASSERT_TRUE(solver.MarginalCovariances({{x}}, &blocks));
  EXPECT_NEAR(blocks[0](0, 0), 0.125, 1e-12);
}

TEST(SolverTest, ReusesTheSymbolicAnalysisWhenThePatternFits) {
  const HyperbolicCamera camera = HyperbolicCamera::Preset("lpa");
  SparseSolver solver;
  FactorGraph first = SmallSlamGraph(camera, 5, 25);
  EXPECT_FALSE(solver.Solve(&first).summary.reused_symbolic_analysis);
  FactorGraph same = SmallSlamGraph(camera, 5, 25);
  const SolveResult again = solver.Solve(&same);
  EXPECT_TRUE(again.summary.reused_symbolic_analysis);
  // And the result is the same as with a fresh analysis.
  FactorGraph fresh_graph = SmallSlamGraph(camera, 5, 25);
  SparseSolver fresh;
  const SolveResult reference = fresh.Solve(&fresh_graph);
  EXPECT_NEAR(again.evidence.log_evidence, reference.evidence.log_evidence, 1e-9);
  FactorGraph other = SmallSlamGraph(camera, 5, 30);
  EXPECT_FALSE(solver.Solve(&other).summary.reused_symbolic_analysis);
}

// A solver that has solved a larger pattern before gives, with
// independent_of_history, exactly a fresh solver's numbers; by default it
// factorises in the larger cached pattern instead.
TEST(SolverTest, IndependentOfHistoryGivesAFreshSolversNumbersExactly) {
  const HyperbolicCamera camera = HyperbolicCamera::Preset("lpa");
  SolverOptions options;
  options.independent_of_history = true;
  FactorGraph sparser_fresh = SmallSlamGraph(camera, 5, 25, 3, 4);
  const SolveResult reference = SparseSolver(options).Solve(&sparser_fresh);
  ASSERT_EQ(reference.summary.termination, TerminationType::kConverged);

  SparseSolver used(options);
  FactorGraph full = SmallSlamGraph(camera, 5, 25);
  used.Solve(&full);
  FactorGraph sparser = SmallSlamGraph(camera, 5, 25, 3, 4);
  const SolveResult after = used.Solve(&sparser);
  EXPECT_FALSE(after.summary.reused_symbolic_analysis);
  EXPECT_EQ(after.evidence.log_evidence, reference.evidence.log_evidence);
  EXPECT_EQ(after.summary.final_cost, reference.summary.final_cost);
  for (int key = 0; key < sparser.num_variables(); ++key)
    EXPECT_EQ(sparser.values().Get(key), sparser_fresh.values().Get(key)) << key;

  SparseSolver reusing;
  FactorGraph full_again = SmallSlamGraph(camera, 5, 25);
  reusing.Solve(&full_again);
  FactorGraph sparser_again = SmallSlamGraph(camera, 5, 25, 3, 4);
  EXPECT_TRUE(reusing.Solve(&sparser_again).summary.reused_symbolic_analysis);
}

// A graph with the last set-up's structure skips the set-up; one with the
// same sizes but other keys must not. Both give a fresh solver's numbers.
TEST(SolverTest, SameStructureAsTheLastSolveGivesAFreshSolversNumbers) {
  const HyperbolicCamera camera = HyperbolicCamera::Preset("lpa");
  SolverOptions options;
  options.independent_of_history = true;
  SparseSolver used(options);
  FactorGraph first = SmallSlamGraph(camera, 5, 25);
  used.Solve(&first);
  auto moved = [&] {
    FactorGraph graph = SmallSlamGraph(camera, 5, 25);
    graph.mutable_values().MutableData(7)[0] += 0.05;
    return graph;
  };
  FactorGraph again = moved(), reference_graph = moved();
  const SolveResult after = used.Solve(&again);
  const SolveResult reference = SparseSolver(options).Solve(&reference_graph);
  EXPECT_TRUE(after.summary.reused_symbolic_analysis);
  EXPECT_EQ(after.evidence.log_evidence, reference.evidence.log_evidence);
  for (int key = 0; key < again.num_variables(); ++key)
    EXPECT_EQ(again.values().Get(key), reference_graph.values().Get(key)) << key;

  // Three poses, two odometry factors: a chain, then a star of the same sizes.
  auto poses = [](bool star) {
    FactorGraph graph;
    for (int i = 0; i < 3; ++i) graph.AddPose(0.2 * i, 0.01 * i * i, 0.1 * i, i == 0);
    const OdometryIncrement step{0.2, 0.05};
    graph.Emplace<OdometryFactor>(0, 1, step, MotionNoiseOptions());
    graph.Emplace<OdometryFactor>(star ? 0 : 1, 2, step, MotionNoiseOptions());
    return graph;
  };
  SparseSolver small(options);
  FactorGraph chain = poses(false), star = poses(true), star_reference = poses(true);
  small.Solve(&chain);
  const SolveResult star_result = small.Solve(&star);
  const SolveResult star_fresh = SparseSolver(options).Solve(&star_reference);
  EXPECT_FALSE(star_result.summary.reused_symbolic_analysis);
  EXPECT_EQ(star_result.summary.final_cost, star_fresh.summary.final_cost);
  EXPECT_EQ(star_result.evidence.log_evidence, star_fresh.evidence.log_evidence);
  for (int key = 0; key < 3; ++key)
    EXPECT_EQ(star.values().Get(key), star_reference.values().Get(key)) << key;
}

// Draws of the solution's Gaussian (for traces where a block per variable
// would cost a solve each): their sample covariance is the dense inverse
// within sampling error, for the simplicial LDL' factor of a small problem
// and the supernodal LL' factor of a bigger one; the same seed repeats them.
TEST(SolverTest, CovarianceSamplesDrawFromTheDenseInverse) {
  const HyperbolicCamera camera = HyperbolicCamera::Preset("lpa");
  struct Case {
    int poses, objects;
  };
  for (const Case c : {Case{25, 3}, Case{120, 14}}) {
    FactorGraph graph = SmallSlamGraph(camera, 4, c.poses, c.objects);
    SolverOptions options;
    options.apply_final_step = false;
    SparseSolver solver(options);
    ASSERT_TRUE(solver.Solve(&graph).summary.IsUsable());
    std::vector<std::vector<int>> groups;
    for (int key = c.poses; key + 1 < graph.num_variables(); key += 2)
      groups.push_back({key, key + 1});
    groups.push_back({5, c.poses - 3});
    std::vector<Eigen::MatrixXd> blocks, draws, again;
    ASSERT_TRUE(solver.MarginalCovariances(groups, &blocks));
    const int count = 20000;
    ASSERT_TRUE(solver.CovarianceSamples(groups, count, 7, &draws));
    ASSERT_TRUE(solver.CovarianceSamples(groups, 3, 7, &again));
    ASSERT_EQ(draws.size(), groups.size());
    for (size_t g = 0; g < groups.size(); ++g) {
      ASSERT_EQ(draws[g].rows(), blocks[g].rows());
      ASSERT_EQ(draws[g].cols(), count);
      EXPECT_TRUE(again[g].isApprox(draws[g].leftCols(3), 1e-12));
      const Eigen::MatrixXd sample = draws[g] * draws[g].transpose() / count;
      for (int r = 0; r < sample.rows(); ++r)
        for (int q = 0; q < sample.cols(); ++q)
          // A sample covariance of n draws has a std of at most
          // sqrt(2 / n) sqrt(S_rr S_qq) (1.4 %): 4 of them.
          EXPECT_NEAR(sample(r, q), blocks[g](r, q),
                      0.06 * std::sqrt(blocks[g](r, r) * blocks[g](q, q)))
              << "group " << g << " (" << r << ", " << q << "), " << c.poses << " poses";
    }
    // All variables' draws at once: each group's rows are its draws above.
    CovarianceDraws all;
    ASSERT_TRUE(solver.CovarianceSamples(groups, 3, 7, &all));
    EXPECT_EQ(all.all.cols(), 3);
    EXPECT_GE(all.all.rows(), 3 * (c.poses - 1));
    Eigen::MatrixXd gathered;
    for (size_t g = 0; g < groups.size(); ++g) {
      all.Gather(g, &gathered);
      EXPECT_EQ(gathered, again[g]) << "group " << g;
    }
    std::vector<Eigen::MatrixXd> none;
    std::string why;
    EXPECT_FALSE(solver.CovarianceSamples(groups, 0, 7, &none, &why));
    EXPECT_FALSE(why.empty());
  }
}

}  // namespace
}  // namespace oslam
