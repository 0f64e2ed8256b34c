#include "slam/landmark_reference.h"

#include <algorithm>
#include <cmath>
#include <limits>
#include <map>
#include <set>

#include <Eigen/Cholesky>

#include "core/error.h"
#include "slam/landmark_factors.h"
#include "solver/factor_graph.h"
#include "solver/sparse_solver.h"

namespace oslam {

std::vector<int> JoinDuplicateLandmarks(const LandmarkDataset& data, const std::vector<int>& ids,
                                        const LandmarkSlamResult& solved, double radius_m,
                                        int* joined) {
  if (ids.size() != data.sightings.size())
    throw Error("joining duplicate landmarks: " + std::to_string(ids.size()) + " ids for " +
                std::to_string(data.sightings.size()) + " sightings");
  std::map<int, std::set<int>> scans;  // id -> poses that see it
  for (size_t k = 0; k < ids.size(); ++k)
    if (ids[k] >= 0) scans[ids[k]].insert(data.sightings[k].pose);
  auto share_a_scan = [&](int a, int b) {
    const std::set<int>& x = scans[a];
    const std::set<int>& y = scans[b];
    return std::any_of(x.begin(), x.end(), [&](int pose) { return y.count(pose) > 0; });
  };
  std::map<int, int> into;
  int count = 0;
  for (size_t a = 0; a < solved.landmarks.size(); ++a)
    for (size_t b = a + 1; b < solved.landmarks.size(); ++b) {
      const MappedLandmark& p = solved.landmarks[a];
      const MappedLandmark& q = solved.landmarks[b];
      if ((p.position_m - q.position_m).norm() > radius_m || into.count(q.id)) continue;
      if (share_a_scan(p.id, q.id)) continue;
      into[q.id] = into.count(p.id) ? into[p.id] : p.id;
      ++count;
    }
  if (joined) *joined = count;
  std::vector<int> out = ids;
  for (int& id : out)
    if (into.count(id)) id = into[id];
  return out;
}

std::vector<int> WorstMisfitSightings(const LandmarkDataset& data, const std::vector<int>& ids,
                                      const LandmarkSlamResult& solved, double gate,
                                      int min_sightings) {
  std::map<int, Eigen::Vector2d> where;
  for (const MappedLandmark& l : solved.landmarks) where[l.id] = l.position_m;
  std::map<int, int> count;
  for (int id : ids)
    if (id >= 0) ++count[id];
  std::map<int, std::pair<double, int>> worst;  // id -> (error, sighting)
  double largest = 0;
  for (size_t k = 0; k < ids.size(); ++k) {
    const auto it = where.find(ids[k]);
    if (ids[k] < 0 || it == where.end() || count[ids[k]] < min_sightings) continue;
    const LandmarkSighting& s = data.sightings[k];
    const double e2 =
        SightingSquaredError(s, solved.trajectory[s.pose], it->second, data.sensor_offset_m);
    if (!(e2 > gate)) continue;
    largest = std::max(largest, e2);
    auto& w = worst[ids[k]];
    if (e2 > w.first) w = {e2, static_cast<int>(k)};
  }
  std::vector<std::pair<double, int>> misfits;
  for (const auto& [id, w] : worst)
    if (w.first >= 0.25 * largest) misfits.push_back(w);
  std::sort(misfits.rbegin(), misfits.rend());
  std::vector<int> sightings;
  for (const auto& m : misfits) sightings.push_back(m.second);
  return sightings;
}

std::vector<int> LeaveOutOutlierSightings(const LandmarkDataset& data, std::vector<int> ids,
                                          const LandmarkSlamOptions& options, double gate,
                                          LandmarkSlamResult* solved, int* removed, int rounds) {
  if (!(gate > 0)) throw Error("leaving out outlier sightings: the gate must be > 0");
  LandmarkSlam slam(options);
  const std::vector<int> given = ids;
  LandmarkSlamResult result = slam.Solve(data, ids);
  for (int round = 0; round < rounds; ++round) {
    // Data snooping in batches (WorstMisfitSightings); a sighting left out
    // that fits the new solve comes back.
    const std::vector<int> misfits = WorstMisfitSightings(data, ids, result, gate);
    std::map<int, Eigen::Vector2d> where;
    for (const MappedLandmark& l : result.landmarks) where[l.id] = l.position_m;
    bool changed = !misfits.empty();
    for (size_t k = 0; k < ids.size(); ++k) {
      const auto it = where.find(given[k]);
      if (ids[k] >= 0 || given[k] < 0 || it == where.end()) continue;
      const LandmarkSighting& s = data.sightings[k];
      if (SightingSquaredError(s, result.trajectory[s.pose], it->second, data.sensor_offset_m) <=
          gate) {
        ids[k] = given[k];
        changed = true;
      }
    }
    for (int k : misfits) ids[k] = -1;
    if (!changed) break;
    result = slam.Solve(data, ids);  // not from the bent solve
  }
  int count = 0;
  for (size_t k = 0; k < ids.size(); ++k) count += given[k] >= 0 && ids[k] < 0;
  if (removed) *removed = count;
  if (solved) *solved = std::move(result);
  return ids;
}

std::vector<SightingErrors> DeletedSightingErrors(
    const LandmarkDataset& data, const std::vector<int>& ids, const LandmarkSlamResult& solved,
    LandmarkSlam* slam, const std::vector<int>& sightings, int held_poses) {
  std::vector<SightingErrors> errors(sightings.size());
  std::vector<size_t> landmark_of(sightings.size());
  std::vector<std::vector<int>> groups;
  std::vector<size_t> grouped;  // which sightings have a group
  for (size_t c = 0; c < sightings.size(); ++c) {
    const int k = sightings[c];
    if (k < 0 || k >= static_cast<int>(ids.size()) || ids[k] < 0) continue;
    const MappedLandmark* landmark = solved.FindLandmark(ids[k]);
    if (!landmark) continue;
    landmark_of[c] = static_cast<size_t>(landmark - solved.landmarks.data());
    const int landmark_key = solved.landmark_position_keys[landmark_of[c]];
    const int pose = data.sightings[k].pose;
    const bool pose_fixed = pose == 0 || pose < held_poses;
    groups.push_back(pose_fixed ? std::vector<int>{landmark_key}
                                : std::vector<int>{solved.pose_keys[pose], landmark_key});
    grouped.push_back(c);
  }
  std::vector<CovarianceRoot> roots;
  if (groups.empty() || !slam->solver().CovarianceRoots(groups, &roots)) return errors;
  for (size_t g = 0; g < grouped.size(); ++g) {
    const size_t c = grouped[g];
    const LandmarkSighting& s = data.sightings[sightings[c]];
    const Pose2& p = solved.trajectory[s.pose];
    FactorGraph one;
    const int pose_key = one.AddPose(p.x, p.y, p.theta);
    const int landmark_key = one.AddVariable(solved.landmarks[landmark_of[c]].position_m);
    AddSightingFactor(&one, pose_key, landmark_key, s, data.sensor_offset_m);
    Eigen::VectorXd e(2);
    Eigen::MatrixXd jacobian = Eigen::MatrixXd::Zero(2, 5);  // (pose, landmark)
    if (!one.factors().front()->Linearize(one.values(), e, &jacobian)) continue;
    const Eigen::MatrixXd j =
        groups[g].size() == 1 ? Eigen::MatrixXd(jacobian.rightCols(2)) : jacobian;
    const Eigen::MatrixXd covariance = RootProduct(roots[g], roots[g]);
    const Eigen::Matrix2d rest = Eigen::Matrix2d::Identity() - j * covariance * j.transpose();
    const Eigen::LDLT<Eigen::Matrix2d> ldlt(rest);
    const bool positive = ldlt.info() == Eigen::Success && ldlt.vectorD().minCoeff() > 1e-12;
    errors[c].at_solve = e.squaredNorm();
    errors[c].deleted = positive ? e.dot(ldlt.solve(e)) : std::numeric_limits<double>::infinity();
  }
  return errors;
}

}  // namespace oslam
