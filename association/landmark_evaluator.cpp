#include "association/landmark_evaluator.h"

#include <algorithm>
#include <chrono>
#include <cmath>
#include <limits>
#include <map>

#include <Eigen/Cholesky>

#include "core/angles.h"
#include "core/error.h"
#include "slam/factors.h"
#include "slam/landmark_factors.h"
#include "solver/factor_graph.h"

namespace oslam {
namespace {

double SecondsSince(std::chrono::steady_clock::time_point t) {
  return std::chrono::duration<double>(std::chrono::steady_clock::now() - t).count();
}

LandmarkSlamOptions FullOptions(const LandmarkTargetOptions& options) {
  LandmarkSlamOptions full = options.slam;
  full.compute_landmark_covariances = false;  // Solve() adds them for the output only
  full.compute_pose_covariances = false;
  return full;
}

LandmarkSlamOptions StepOptions(const LandmarkTargetOptions& options) {
  LandmarkSlamOptions step = FullOptions(options);
  step.solver.max_iterations = options.proposal_iterations;
  return step;
}

}  // namespace

bool LandmarkTargetOptions::Validate(std::string* why) const {
  if (!(slam.landmark_prior_std_m > 0) && !(slam.landmark_density_per_m2 > 0)) {
    if (why)
      *why =
          "the landmarks need a location prior, a density or a Gaussian std > 0 (a flat prior "
          "makes the evidence improper across landmark counts)";
    return false;
  }
  if (proposal_iterations < 1 || local_iterations < 1) {
    if (why) *why = "the solver iterations per proposal must be >= 1";
    return false;
  }
  if (max_cache_entries < 1) {
    if (why) *why = "the state cache needs room for at least one entry";
    return false;
  }
  return slam.Validate(why);
}

size_t LandmarkEvaluator::BlockHash::operator()(const std::vector<int>& block) const {
  size_t h = block.size();
  for (int t : block) h ^= std::hash<int>()(t) + 0x9e3779b97f4a7c15ull + (h << 6) + (h >> 2);
  return h;
}

LandmarkEvaluator::LandmarkEvaluator(const LandmarkTargetData& data,
                                     const LandmarkTargetOptions& options)
    : data_(data),
      options_(options),
      full_(std::make_unique<LandmarkSlam>(FullOptions(options))),
      step_(StepOptions(options)),
      trial_(FullOptions(options)) {
  std::string why;
  if (!options.Validate(&why)) throw Error("landmark O-SLAM target options: " + why);
  if (!data.data) throw Error("landmark O-SLAM target: no data set");
  SolverOptions local = options.slam.solver;
  local.max_iterations = options.local_iterations;
  local.reuse_symbolic_analysis = false;
  local_solver_.set_options(local);
}

std::vector<int> LandmarkEvaluator::Association(const AssociationState& state) const {
  std::vector<int> association(data_.data->sightings.size(), -1);
  for (const auto& block : state.blocks)
    for (int t : block)
      for (int k : data_.tracks.at(t)) association[k] = block.front();
  return association;
}

std::vector<int> LandmarkEvaluator::SightingsOf(const std::vector<int>& block) const {
  std::vector<int> sightings;
  for (int t : block)
    sightings.insert(sightings.end(), data_.tracks[t].begin(), data_.tracks[t].end());
  return sightings;
}

LandmarkSlamResult LandmarkEvaluator::WarmStart(const StateEvaluation& from) const {
  LandmarkSlamResult warm;
  if (from.solution) warm.trajectory = from.solution->trajectory;
  for (size_t j = 0; j < from.state.blocks.size() && j < from.locations.size(); ++j) {
    MappedLandmark l;
    l.id = from.state.blocks[j].front();
    l.position_m = from.locations[j].head<2>();
    warm.landmarks.push_back(l);
  }
  std::sort(warm.landmarks.begin(), warm.landmarks.end(),
            [](const MappedLandmark& a, const MappedLandmark& b) { return a.id < b.id; });
  return warm;
}

double SightingResidual2(const LandmarkDataset& data, const std::vector<Pose2>& trajectory,
                         const std::vector<int>& sightings, const Eigen::Vector2d& landmark_m) {
  double sum = 0;
  for (int k : sightings) {
    const LandmarkSighting& s = data.sightings[k];
    sum += SightingSquaredError(s, trajectory[s.pose], landmark_m, data.sensor_offset_m);
  }
  return sum;
}

bool LandmarkEvaluator::SharesAScan(const std::vector<int>& block) const {
  if (!options_.one_sighting_per_scan || block.size() < 2) return false;
  std::vector<int> poses;
  for (int t : block)
    for (int k : data_.tracks[t]) poses.push_back(data_.data->sightings[k].pose);
  std::sort(poses.begin(), poses.end());
  return std::adjacent_find(poses.begin(), poses.end()) != poses.end();
}

EvaluationPtr LandmarkEvaluator::FullEvaluation(const AssociationState& state,
                                                const StateEvaluation* from, Solver solver) {
  const auto start = std::chrono::steady_clock::now();
  const bool refine = solver == Solver::kRefine;
  const LandmarkDataset& data = *data_.data;
  if (solver == Solver::kStep)
    for (const auto& block : state.blocks)
      if (SharesAScan(block)) {
        auto invalid = std::make_shared<StateEvaluation>();
        invalid->state = state;
        return invalid;  // valid = false: rejected
      }
  LandmarkSlamResult warm;
  const bool use_warm = from != nullptr;
  if (use_warm) warm = WarmStart(*from);
  LandmarkSlam& slam = refine ? *full_ : solver == Solver::kStep ? step_ : trial_;
  const LandmarkSlamResult result =
      slam.Solve(data, Association(state), use_warm ? &warm : nullptr);
  ++solves_;
  auto evaluation = std::make_shared<StateEvaluation>();
  evaluation->state = state;
  evaluation->valid = result.summary.IsUsable() && result.evidence.valid &&
                      std::isfinite(result.evidence.log_evidence);
  evaluation->log_target = result.evidence.log_evidence;
  auto solution = std::make_shared<GeometricSlamResult>();
  solution->trajectory = result.trajectory;
  solution->summary = result.summary;
  solution->evidence = result.evidence;
  evaluation->solution = std::move(solution);
  if (refine) last_refine_keys_.clear();
  for (const auto& block : state.blocks) {
    const MappedLandmark* l = result.FindLandmark(block.front());
    if (refine)
      last_refine_keys_.push_back(l ? result.landmark_position_keys[l - result.landmarks.data()]
                                    : -1);
    const Eigen::Vector2d p = l ? l->position_m : Eigen::Vector2d::Zero();
    evaluation->locations.push_back(Eigen::Vector3d(p.x(), p.y(), 0));
    evaluation->residual2.push_back(
        SightingResidual2(data, result.trajectory, SightingsOf(block), p));
  }
  evaluation->evaluation_time_s = SecondsSince(start);
  return evaluation;
}

const LandmarkEvaluator::BlockValue& LandmarkEvaluator::LocalBlock(const std::vector<int>& block,
                                                                   const StateEvaluation* from) {
  const auto found = block_cache_.find(block);
  if (found != block_cache_.end()) return found->second;
  const LandmarkDataset& data = *data_.data;
  const std::vector<Pose2>& trajectory = reference_->solution->trajectory;
  const std::vector<int> sightings = SightingsOf(block);
  // Start where `from` has the block of the earliest track, else at the
  // first sighting with a bearing.
  Eigen::Vector2d start = Eigen::Vector2d::Zero();
  bool placed = false;
  if (from) {
    const int j = from->state.BlockOf(block.front());
    if (j >= 0 && j < static_cast<int>(from->locations.size())) {
      start = from->locations[j].head<2>();
      placed = true;
    }
  }
  double diameter_sum = 0;
  int diameters = 0;
  for (int k : sightings) {
    const LandmarkSighting& s = data.sightings[k];
    if (!placed && s.range_m > 0) {
      start = LandmarkFromRangeBearing(trajectory[s.pose], s.range_m, s.bearing_rad,
                                       data.sensor_offset_m);
      placed = true;
    }
    if (std::isfinite(s.diameter_m)) {
      diameter_sum += s.diameter_m;
      ++diameters;
    }
  }
  FactorGraph graph;
  const int landmark = graph.AddVariable(start);
  const int diameter =
      diameters > 0 ? graph.AddVariable(Eigen::Matrix<double, 1, 1>(diameter_sum / diameters)) : -1;
  const double prior_var = options_.slam.landmark_prior_std_m * options_.slam.landmark_prior_std_m;
  if (prior_var > 0)
    graph.Emplace<PriorFactor>(landmark, Eigen::VectorXd(options_.slam.landmark_prior_mean_m),
                               Eigen::MatrixXd(Eigen::Matrix2d::Identity() * prior_var),
                               "landmark prior");
  const Eigen::Matrix<double, 1, 1> diameter_var(options_.slam.diameter_std_m *
                                                 options_.slam.diameter_std_m);
  std::map<int, int> pose_keys;
  for (int k : sightings) {
    const LandmarkSighting& s = data.sightings[k];
    auto it = pose_keys.find(s.pose);
    if (it == pose_keys.end()) {
      const Pose2& p = trajectory[s.pose];
      it = pose_keys.emplace(s.pose, graph.AddPose(p.x, p.y, p.theta, /*fixed=*/true)).first;
    }
    AddSightingFactor(&graph, it->second, landmark, s, data.sensor_offset_m);
    if (diameter >= 0 && std::isfinite(s.diameter_m))
      graph.Emplace<PriorFactor>(diameter, Eigen::Matrix<double, 1, 1>(s.diameter_m), diameter_var,
                                 "diameter");
  }
  const SolveResult solved = local_solver_.Solve(&graph);
  ++solves_;
  BlockValue value;
  value.log_evidence = solved.summary.IsUsable() && solved.evidence.valid
                           ? solved.evidence.log_evidence + options_.slam.LogLandmarkDensity()
                           : -std::numeric_limits<double>::infinity();
  value.position_m = graph.values().Get(landmark);
  value.residual2 = SightingResidual2(data, trajectory, sightings, value.position_m);
  return block_cache_.emplace(block, value).first->second;
}

EvaluationPtr LandmarkEvaluator::LocalEvaluation(const AssociationState& state,
                                                 const StateEvaluation* from) {
  const auto start = std::chrono::steady_clock::now();
  auto evaluation = std::make_shared<StateEvaluation>();
  evaluation->state = state;
  evaluation->solution = reference_->solution;
  for (const auto& block : state.blocks)
    if (!reference_blocks_.count(block) && SharesAScan(block)) return evaluation;  // invalid
  if (options_.mode == LandmarkEvaluationMode::kMarginal &&
      MarginalMergeEvaluation(state, evaluation.get())) {
    evaluation->evaluation_time_s = SecondsSince(start);
    return evaluation;
  }
  std::vector<char> kept(reference_->state.blocks.size(), 0);
  double log_target = reference_->log_target;
  for (const auto& block : state.blocks) {
    const auto in_reference = reference_blocks_.find(block);
    if (in_reference != reference_blocks_.end()) {
      const int j = in_reference->second;
      kept[j] = 1;
      evaluation->locations.push_back(reference_->locations[j]);
      evaluation->residual2.push_back(reference_->residual2[j]);
      continue;
    }
    const BlockValue& value = LocalBlock(block, from);
    log_target += value.log_evidence;
    evaluation->locations.push_back(Eigen::Vector3d(value.position_m.x(), value.position_m.y(), 0));
    evaluation->residual2.push_back(value.residual2);
  }
  for (size_t j = 0; j < kept.size(); ++j)
    if (!kept[j])
      log_target -= LocalBlock(reference_->state.blocks[j], reference_.get()).log_evidence;
  evaluation->log_target = log_target;
  evaluation->valid = std::isfinite(log_target);
  evaluation->evaluation_time_s = SecondsSince(start);
  return evaluation;
}

bool LandmarkEvaluator::MarginalMergeEvaluation(const AssociationState& state,
                                                StateEvaluation* evaluation) {
  if (state.blocks.size() + 1 != reference_->state.blocks.size()) return false;
  // One merge of two reference blocks? Then every other block is unchanged.
  int added = -1, others = 0;
  for (size_t j = 0; j < state.blocks.size(); ++j)
    if (!reference_blocks_.count(state.blocks[j])) {
      added = static_cast<int>(j);
      ++others;
    }
  const int ja = added >= 0 ? reference_->state.BlockOf(state.blocks[added].front()) : -1;
  int jb = -1;
  if (ja >= 0 && others == 1)
    for (int t : state.blocks[added]) {
      const int j = reference_->state.BlockOf(t);
      if (j != ja) {
        jb = j;
        break;
      }
    }
  double delta = 0;
  Eigen::Vector2d mean;
  if (jb < 0 ||
      reference_->state.blocks[ja].size() + reference_->state.blocks[jb].size() !=
          state.blocks[added].size() ||
      !MergeDelta(ja, jb, &delta, &mean))
    return false;
  for (size_t j = 0; j < state.blocks.size(); ++j) {
    if (static_cast<int>(j) == added) {
      evaluation->locations.push_back(Eigen::Vector3d(mean.x(), mean.y(), 0));
      evaluation->residual2.push_back(SightingResidual2(
          *data_.data, reference_->solution->trajectory, SightingsOf(state.blocks[j]), mean));
      continue;
    }
    const int r = reference_blocks_.at(state.blocks[j]);
    evaluation->locations.push_back(reference_->locations[r]);
    evaluation->residual2.push_back(reference_->residual2[r]);
  }
  evaluation->log_target = reference_->log_target + delta;
  evaluation->valid = true;
  return true;
}

void LandmarkEvaluator::Store(const EvaluationPtr& evaluation) {
  if (cache_.size() >= options_.max_cache_entries) cache_.clear();
  cache_[evaluation->state] = evaluation;
}

EvaluationPtr LandmarkEvaluator::Evaluate(const AssociationState& state,
                                          const StateEvaluation* from) {
  const auto found = cache_.find(state);
  if (found != cache_.end()) {
    ++hits_;
    return found->second;
  }
  if (options_.mode != LandmarkEvaluationMode::kExact && !reference_) return Refine(state, from);
  EvaluationPtr evaluation = options_.mode == LandmarkEvaluationMode::kExact
                                 ? FullEvaluation(state, from, Solver::kStep)
                                 : LocalEvaluation(state, from);
  Store(evaluation);
  return evaluation;
}

EvaluationPtr LandmarkEvaluator::Refine(const AssociationState& state,
                                        const StateEvaluation* from) {
  EvaluationPtr evaluation = FullEvaluation(state, from, Solver::kRefine);
  if (options_.mode != LandmarkEvaluationMode::kExact && evaluation->valid) {
    SetReference(evaluation);
    reference_factorised_ = true;
    reference_position_keys_ = last_refine_keys_;
    roots_.clear();  // of the factor before
    root_bytes_ = 0;
    cross_covariances_.clear();
  }
  Store(evaluation);
  return evaluation;
}

EvaluationPtr LandmarkEvaluator::Trial(const AssociationState& state, const StateEvaluation* from) {
  for (const auto& block : state.blocks)
    if (!reference_blocks_.count(block) && SharesAScan(block)) {
      auto invalid = std::make_shared<StateEvaluation>();
      invalid->state = state;
      return invalid;  // valid = false
    }
  return FullEvaluation(state, from, Solver::kTrial);
}

// The location priors' part of merging extra + 1 landmarks into one (extra
// priors fewer): their information and information times mean taken out of
// the merged position's, and their log normalisers with the 2 pi of the
// integral: extra (log s^2 + |m|^2 / (2 s^2)) under a Gaussian prior,
// -extra log(2 pi lambda) under a density.
LandmarkEvaluator::PriorTerms LandmarkEvaluator::PriorTermsOf(int extra) const {
  PriorTerms terms;
  const LandmarkSlamOptions& slam = options_.slam;
  if (slam.landmark_prior_std_m > 0) {
    const double s2 = slam.landmark_prior_std_m * slam.landmark_prior_std_m;
    terms.information = extra / s2;
    terms.information_mean = extra * slam.landmark_prior_mean_m / s2;
    terms.log_term = extra * (std::log(s2) + 0.5 * slam.landmark_prior_mean_m.squaredNorm() / s2);
  } else {
    terms.log_term = -extra * (std::log(2 * kPi) + slam.LogLandmarkDensity());
  }
  return terms;
}

bool LandmarkEvaluator::MergeDelta(int ja, int jb, double* delta, Eigen::Vector2d* mean) {
  if (!reference_factorised_) return false;
  const int ka = reference_position_keys_[ja], kb = reference_position_keys_[jb];
  if (ka < 0 || kb < 0) return false;
  Eigen::Matrix4d sigma;
  if (!JointCovariance(ka, kb, &sigma)) return false;
  ++marginal_merges_;
  // Laplace evidence ratio of "l_a = l_b = l" (one location prior instead of
  // two): with the reference's Gaussian N(mu, Sigma) over (l_a, l_b) and
  // H = [I; I], under a Gaussian prior N(m, s^2 I)
  //   log int N(H l; mu, Sigma) / N(l; m, s^2 I) dl
  //   = -1/2 log|Sigma| + 2 log s - 1/2 log|P| + 1/2 b'P^-1 b - 1/2 mu'Lambda mu + |m|^2 / (2 s^2)
  // with Lambda = Sigma^-1, P = H'Lambda H - I / s^2, b = H'Lambda mu - m / s^2;
  // under a density lambda the same with 1/s^2 = 0 and 2 log s replaced by
  // -log(2 pi lambda): log N(mu_a - mu_b; 0, S) - log lambda, S the
  // covariance of the difference.
  Eigen::Vector4d mu;
  mu << reference_->locations[ja].head<2>(), reference_->locations[jb].head<2>();
  const Eigen::LLT<Eigen::Matrix4d> sigma_llt(sigma);
  if (sigma_llt.info() != Eigen::Success) return false;
  const Eigen::Matrix4d lambda = sigma_llt.solve(Eigen::Matrix4d::Identity());
  Eigen::Matrix<double, 4, 2> h;
  h << Eigen::Matrix2d::Identity(), Eigen::Matrix2d::Identity();
  const PriorTerms prior = PriorTermsOf(1);
  const Eigen::Matrix2d p =
      h.transpose() * lambda * h - Eigen::Matrix2d::Identity() * prior.information;
  const Eigen::Vector2d b = h.transpose() * lambda * mu - prior.information_mean;
  const Eigen::LLT<Eigen::Matrix2d> p_llt(p);
  if (p_llt.info() != Eigen::Success) return false;
  const Eigen::Vector2d l = p_llt.solve(b);
  double log_det_sigma = 0, log_det_p = 0;
  for (int i = 0; i < 4; ++i) log_det_sigma += 2 * std::log(sigma_llt.matrixL()(i, i));
  for (int i = 0; i < 2; ++i) log_det_p += 2 * std::log(p_llt.matrixL()(i, i));
  *delta = -0.5 * log_det_sigma - 0.5 * log_det_p + 0.5 * b.dot(l) - 0.5 * mu.dot(lambda * mu) +
           prior.log_term;
  *delta += DiameterMergeDelta({ja, jb});
  *mean = l;
  return std::isfinite(*delta);
}

bool LandmarkEvaluator::MergeGain(const StateEvaluation& at, int ja, int jb, double* gain) {
  if (options_.mode != LandmarkEvaluationMode::kMarginal || reference_.get() != &at || ja == jb)
    return false;
  const auto& blocks = reference_->state.blocks;
  std::vector<int> both(blocks[ja]);
  both.insert(both.end(), blocks[jb].begin(), blocks[jb].end());
  if (SharesAScan(both)) {  // as LocalEvaluation: invalid
    *gain = -std::numeric_limits<double>::infinity();
    return true;
  }
  Eigen::Vector2d mean;
  return MergeDelta(std::min(ja, jb), std::max(ja, jb), gain, &mean);
}

bool LandmarkEvaluator::SplitGain(const StateEvaluation& at, int j, int track, double* gain) {
  if (options_.mode == LandmarkEvaluationMode::kExact || reference_.get() != &at || j < 0 ||
      j >= static_cast<int>(at.state.blocks.size()))
    return false;
  const std::vector<int>& block = at.state.blocks[j];
  if (block.size() < 2 || std::find(block.begin(), block.end(), track) == block.end()) return false;
  // As LocalEvaluation: the two new blocks' local values in, the old one's
  // out (a part of a reference block is never a reference block itself).
  std::vector<int> rest;
  for (int t : block)
    if (t != track) rest.push_back(t);
  if (SharesAScan(rest)) {
    *gain = -std::numeric_limits<double>::infinity();
    return true;
  }
  const double parts = LocalBlock(rest, &at).log_evidence + LocalBlock({track}, &at).log_evidence;
  *gain = parts - LocalBlock(block, reference_.get()).log_evidence;
  return true;
}

bool LandmarkEvaluator::JointMergeDelta(const AssociationState& state,
                                        const std::vector<std::vector<int>>& groups,
                                        double* delta) {
  if (!reference_factorised_ || !reference_ || !(reference_->state == state)) return false;
  // MergeDelta's integral with several groups: x the positions of every
  // block concerned (M of them), N(x; mu, Sigma) the reference's marginal,
  // x = H l with l one position per group (G of them), and each group of n
  // blocks keeping one location prior instead of n:
  //   log int N(H l; mu, Sigma) prod_g N(l_g; m, s^2 I)^-(n_g - 1) dl
  //   = -1/2 log|Sigma| - 1/2 log|P| + 1/2 b'P^-1 b - 1/2 mu'Lambda mu
  //     + sum_g (n_g - 1) (log s^2 + |m|^2 / (2 s^2)),
  // P = H'Lambda H - diag((n_g - 1) / s^2), b = H'Lambda mu - ((n_g - 1) m / s^2)_g
  // (the 2 pi factors cancel since sum_g n_g = M).
  std::vector<int> blocks, keys;
  for (const auto& group : groups) {
    if (group.size() < 2) return false;
    for (int j : group) {
      if (j < 0 || j >= static_cast<int>(reference_position_keys_.size()) ||
          reference_position_keys_[j] < 0)
        return false;
      blocks.push_back(j);
      keys.push_back(reference_position_keys_[j]);
    }
  }
  const int m_blocks = static_cast<int>(blocks.size()), g_count = static_cast<int>(groups.size());
  PrepareMerges(blocks);
  Eigen::MatrixXd sigma(2 * m_blocks, 2 * m_blocks);
  for (int a = 0; a < m_blocks; ++a)
    for (int b = a; b < m_blocks; ++b) {
      // Kept per pair of keys at this reference: a screen scores many
      // overlapping sets of merges.
      const std::pair<int, int> pair_keys(std::min(keys[a], keys[b]), std::max(keys[a], keys[b]));
      auto kept = cross_covariances_.find(pair_keys);
      if (kept == cross_covariances_.end()) {
        Eigen::Matrix4d pair;
        if (!JointCovariance(pair_keys.first, pair_keys.second, &pair)) return false;
        if (cross_covariances_.size() >= kMaxCrossCovariances) cross_covariances_.clear();
        kept = cross_covariances_.emplace(pair_keys, pair).first;
      }
      const Eigen::Matrix4d& pair = kept->second;
      const bool swapped = keys[a] > keys[b];
      if (a == b) {
        sigma.block<2, 2>(2 * a, 2 * a) = pair.topLeftCorner<2, 2>();
        continue;
      }
      sigma.block<2, 2>(2 * a, 2 * b) =
          swapped ? pair.bottomLeftCorner<2, 2>() : pair.topRightCorner<2, 2>();
      sigma.block<2, 2>(2 * b, 2 * a) = sigma.block<2, 2>(2 * a, 2 * b).transpose();
    }
  Eigen::VectorXd mu(2 * m_blocks);
  Eigen::MatrixXd h = Eigen::MatrixXd::Zero(2 * m_blocks, 2 * g_count);
  for (int g = 0, row = 0; g < g_count; ++g)
    for (size_t i = 0; i < groups[g].size(); ++i, ++row) {
      mu.segment<2>(2 * row) = reference_->locations[groups[g][i]].head<2>();
      h.block<2, 2>(2 * row, 2 * g).setIdentity();
    }
  const Eigen::LLT<Eigen::MatrixXd> sigma_llt(sigma);
  if (sigma_llt.info() != Eigen::Success) return false;
  const Eigen::MatrixXd lambda_h = sigma_llt.solve(h);
  const Eigen::VectorXd lambda_mu = sigma_llt.solve(mu);
  Eigen::MatrixXd p = h.transpose() * lambda_h;
  Eigen::VectorXd b = h.transpose() * lambda_mu;
  double prior_terms = 0;
  for (int g = 0; g < g_count; ++g) {
    const PriorTerms prior = PriorTermsOf(static_cast<int>(groups[g].size()) - 1);
    p.block<2, 2>(2 * g, 2 * g) -= Eigen::Matrix2d::Identity() * prior.information;
    b.segment<2>(2 * g) -= prior.information_mean;
    prior_terms += prior.log_term;
  }
  const Eigen::LLT<Eigen::MatrixXd> p_llt(p);
  if (p_llt.info() != Eigen::Success) return false;
  double log_det_sigma = 0, log_det_p = 0;
  for (int i = 0; i < sigma.rows(); ++i) log_det_sigma += 2 * std::log(sigma_llt.matrixL()(i, i));
  for (int i = 0; i < p.rows(); ++i) log_det_p += 2 * std::log(p_llt.matrixL()(i, i));
  *delta = -0.5 * log_det_sigma - 0.5 * log_det_p + 0.5 * b.dot(p_llt.solve(b)) -
           0.5 * mu.dot(lambda_mu) + prior_terms;
  for (const auto& group : groups) *delta += DiameterMergeDelta(group);
  ++marginal_merges_;
  return std::isfinite(*delta);
}

void LandmarkEvaluator::PrepareMerges(const std::vector<int>& blocks) {
  if (!reference_factorised_) return;
  std::vector<std::vector<int>> missing;
  for (int j : blocks) {
    const int key = j >= 0 && j < static_cast<int>(reference_position_keys_.size())
                        ? reference_position_keys_[j]
                        : -1;
    if (key >= 0 && !roots_.count(key)) missing.push_back({key});
  }
  std::sort(missing.begin(), missing.end());
  missing.erase(std::unique(missing.begin(), missing.end()), missing.end());
  // The roots' rows are their keys' elimination-tree ancestors; at most
  // kMaxRootBytes kept.
  constexpr size_t kChunk = 32;  // keys per call (a batch of dense solves on a supernodal factor)
  for (size_t first = 0; first < missing.size(); first += kChunk) {
    const std::vector<std::vector<int>> chunk(
        missing.begin() + first, missing.begin() + std::min(missing.size(), first + kChunk));
    std::vector<CovarianceRoot> roots;
    if (!full_->solver().CovarianceRoots(chunk, &roots)) return;  // LDL': pairwise blocks
    double bytes = 0;
    for (const CovarianceRoot& root : roots) bytes += double(root.bytes());
    if (root_bytes_ + bytes > kMaxRootBytes) {
      if (first > 0) return;  // keep what this call computed
      roots_.clear();
      root_bytes_ = 0;
    }
    root_bytes_ += bytes;
    for (size_t i = 0; i < chunk.size(); ++i) roots_[chunk[i].front()] = std::move(roots[i]);
  }
}

bool LandmarkEvaluator::JointCovariance(int ka, int kb, Eigen::Matrix4d* sigma) {
  const auto a = roots_.find(ka), b = roots_.find(kb);
  if (a != roots_.end() && b != roots_.end() && a->second.values.cols() == 2 &&
      b->second.values.cols() == 2) {
    sigma->topLeftCorner<2, 2>() = RootProduct(a->second, a->second);
    sigma->bottomRightCorner<2, 2>() = RootProduct(b->second, b->second);
    sigma->topRightCorner<2, 2>() = RootProduct(a->second, b->second);
    sigma->bottomLeftCorner<2, 2>() = sigma->topRightCorner<2, 2>().transpose();
    return true;
  }
  std::vector<Eigen::MatrixXd> blocks;
  if (!full_->solver().MarginalCovariances({{ka, kb}}, &blocks) || blocks.size() != 1 ||
      blocks[0].rows() != 4)
    return false;
  *sigma = blocks[0];
  return true;
}

double LandmarkEvaluator::DiameterMergeDelta(const std::vector<int>& group) const {
  // The trunk diameters: a variable per landmark (flat prior) tied only to
  // its own measurements, so its part of the evidence is separate and exact:
  // merging k blocks with measurements (counts n_i, means d_i, N = sum n_i,
  // D = sum n_i d_i / N) adds
  //   -1/(2 sigma^2) sum n_i (d_i - D)^2 + 1/2 log(prod n_i / N) - (k - 1)/2 log(2 pi sigma^2),
  // for two blocks -n_a n_b / (2 N sigma^2) (d_a - d_b)^2 + 1/2 log(n_a n_b / (2 pi sigma^2 N)).
  double total = 0, weighted = 0, log_counts = 0;
  std::vector<std::pair<int, double>> measured;  // (count, mean)
  for (int j : group) {
    int count = 0;
    double sum = 0;
    for (int t : reference_->state.blocks[j])
      for (int k : data_.tracks[t]) {
        const double d = data_.data->sightings[k].diameter_m;
        if (!std::isfinite(d)) continue;
        sum += d;
        ++count;
      }
    if (count == 0) continue;
    measured.push_back({count, sum / count});
    total += count;
    weighted += sum;
    log_counts += std::log(double(count));
  }
  if (measured.size() < 2) return 0;
  const double var = options_.slam.diameter_std_m * options_.slam.diameter_std_m;
  const double mean = weighted / total;
  double spread = 0;
  for (const auto& [count, d] : measured) spread += count * (d - mean) * (d - mean);
  return -spread / (2 * var) + 0.5 * (log_counts - std::log(total)) -
         0.5 * double(measured.size() - 1) * std::log(2 * kPi * var);
}

void LandmarkEvaluator::SetReference(const EvaluationPtr& evaluation) {
  // A new linearisation point: values computed at the old one are stale.
  reference_ = evaluation;
  reference_factorised_ = false;
  reference_blocks_.clear();
  for (size_t j = 0; j < evaluation->state.blocks.size(); ++j)
    reference_blocks_[evaluation->state.blocks[j]] = static_cast<int>(j);
  block_cache_.clear();
  cache_.clear();
}

void LandmarkEvaluator::SwapWithStash() {
  std::swap(full_, stash_.full);
  std::swap(reference_, stash_.reference);
  std::swap(reference_factorised_, stash_.factorised);
  std::swap(reference_position_keys_, stash_.position_keys);
  std::swap(last_refine_keys_, stash_.last_refine_keys);
  std::swap(reference_blocks_, stash_.blocks);
  std::swap(block_cache_, stash_.block_cache);
  std::swap(cache_, stash_.cache);
  std::swap(roots_, stash_.roots);
  std::swap(root_bytes_, stash_.root_bytes);
  std::swap(cross_covariances_, stash_.cross_covariances);
}

void LandmarkEvaluator::StashReference() {
  if (stash_.held) throw Error("landmark O-SLAM target: a reference is set aside already");
  if (!stash_.full) stash_.full = std::make_unique<LandmarkSlam>(FullOptions(options_));
  SwapWithStash();  // the live members now empty: the stash holds nothing else while not held
  stash_.held = true;
}

EvaluationPtr LandmarkEvaluator::RestoreReference() {
  if (!stash_.held) throw Error("landmark O-SLAM target: no reference set aside");
  SwapWithStash();
  stash_.held = false;
  // The dropped reference's values go; its solver stays for the next stash.
  std::unique_ptr<LandmarkSlam> spare = std::move(stash_.full);
  stash_ = StashedReference();
  stash_.full = std::move(spare);
  return reference_;
}

void LandmarkEvaluator::Remember(const EvaluationPtr& evaluation) {
  Store(evaluation);
}

LandmarkSlamResult LandmarkEvaluator::Solve(const AssociationState& state,
                                            const StateEvaluation* from) {
  LandmarkSlamOptions options = options_.slam;
  options.compute_landmark_covariances = true;
  options.held_poses = 0;
  LandmarkSlam slam(options);
  LandmarkSlamResult warm;
  if (from) warm = WarmStart(*from);
  return slam.Solve(*data_.data, Association(state), from ? &warm : nullptr);
}

}  // namespace oslam
