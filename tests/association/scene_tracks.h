// A small O-SLAM association problem with known truth, for the tests of the
// evaluator and of the baselines: the synthetic loop of slam/synthetic_scene.h
// (one lap, four objects), its detections cut into atomic tracks of at most
// `max_track_length` consecutive frames, so that every object is several
// tracks. The true state joins each object's tracks with its true class.
#pragma once

#include <algorithm>
#include <map>
#include <memory>
#include <utility>
#include <vector>

#include "association/association_state.h"
#include "association/slam_target.h"
#include "association/tracks.h"
#include "calib/hyperbolic_camera.h"
#include "slam/synthetic_scene.h"

namespace oslam::testing {

struct SceneTracks {
  // Shared, so that data.camera stays valid when the struct is moved.
  std::shared_ptr<const HyperbolicCamera> camera =
      std::make_shared<HyperbolicCamera>(HyperbolicCamera::Preset("lpa"));
  SyntheticScene scene;
  SlamTargetData data;
  std::vector<int> track_object;  // true object of each track
  std::vector<int> track_class;   // its detected (here: true) class
  std::vector<int> track_size;    // its number of detections
  AssociationState truth;

  AssociationState Separate() const { return SeparateTracksState(track_class); }
  // Identity confusion: the detected class is the true one, P = 0.98.
  ClassConfusionModel Model() const {
    return ClassConfusionModel({{0.98, 0.02}, {0.02, 0.98}}, 1e-3, track_class, track_size);
  }
  // The tracks of object j, in time order.
  std::vector<int> TracksOf(int object) const {
    std::vector<int> tracks;
    for (size_t t = 0; t < track_object.size(); ++t)
      if (track_object[t] == object) tracks.push_back(static_cast<int>(t));
    return tracks;
  }
};

inline SyntheticSceneOptions SmallLoop() {
  SyntheticSceneOptions options;
  options.num_poses = 86;  // one lap of the 3 m x 2 m rectangle
  options.num_objects = 4;
  options.loop_length_m = 3.0;
  options.loop_width_m = 2.0;
  options.max_range_m = 2.5;
  options.pixel_std_px = 3.0;
  options.odometry_noise = true;
  options.seed = 3;
  return options;
}

inline SceneTracks MakeSceneTracks(int max_track_length = 8,
                                   const SyntheticSceneOptions& options = SmallLoop()) {
  SceneTracks s;
  s.scene = MakeSyntheticScene(*s.camera, options);
  const GeometricSlamProblem& problem = s.scene.problem;
  s.data.camera = s.camera.get();
  s.data.increments = problem.increments;
  s.data.first_pose = problem.first_pose;
  s.data.classes = problem.classes;
  // Detections in frame order (as the observations come); a track ends at a
  // missed frame or at max_track_length detections.
  std::map<int, Track> open;                  // by object
  std::vector<std::pair<int, Track>> closed;  // (object, track)
  for (const SliceObservation& o : problem.observations) {
    const int d = static_cast<int>(s.data.detections.size());
    const int c = problem.object_class.at(o.object_id);
    s.data.detections.push_back({o.frame, c, o.slice});
    auto it = open.find(o.object_id);
    if (it != open.end() && (s.data.detections[it->second.detections.back()].frame != o.frame - 1 ||
                             static_cast<int>(it->second.detections.size()) >= max_track_length)) {
      closed.emplace_back(o.object_id, it->second);
      open.erase(it);
      it = open.end();
    }
    if (it == open.end()) {
      Track t;
      t.class_index = c;
      it = open.emplace(o.object_id, t).first;
    }
    it->second.detections.push_back(d);
  }
  for (const auto& [object, track] : open) closed.emplace_back(object, track);
  // Track ids in order of first detection, as BuildTracks numbers them.
  std::sort(closed.begin(), closed.end(), [](const auto& a, const auto& b) {
    return a.second.detections[0] < b.second.detections[0];
  });
  std::map<int, std::vector<int>> blocks;
  for (size_t t = 0; t < closed.size(); ++t) {
    Track track = closed[t].second;
    track.id = static_cast<int>(t);
    s.data.tracks.push_back(track);
    s.track_object.push_back(closed[t].first);
    s.track_class.push_back(track.class_index);
    s.track_size.push_back(static_cast<int>(track.detections.size()));
    blocks[closed[t].first].push_back(track.id);
  }
  for (const auto& [object, block] : blocks) {
    s.truth.blocks.push_back(block);
    s.truth.classes.push_back(problem.object_class.at(object));
  }
  s.truth.Canonicalize();
  return s;
}

}  // namespace oslam::testing
