#include "association/nn_baseline.h"

#include <cmath>
#include <limits>

#include "core/error.h"

namespace oslam {

bool NearestNeighbourOptions::Validate(std::string* why) const {
  if (!(gate_m > 0) || std::isinf(gate_m)) {
    if (why) *why = "the nearest-neighbour gate must be a positive distance";
    return false;
  }
  return true;
}

AssociationState NearestNeighbourAssociation(const StateEvaluation& separate,
                                             const NearestNeighbourOptions& options) {
  std::string why;
  if (!options.Validate(&why)) throw Error(why);
  struct Object {
    std::vector<int> tracks;
    int class_index;
    Eigen::Vector3d sum;
  };
  std::vector<Object> objects;
  // Blocks of the separate state are single tracks in time order.
  for (size_t t = 0; t < separate.state.blocks.size(); ++t) {
    const Eigen::Vector3d& location = separate.locations[t];
    const int c = separate.state.classes[t];
    int best = -1;
    double best_distance = options.gate_m;
    for (size_t j = 0; j < objects.size(); ++j) {
      if (objects[j].class_index != c) continue;
      const double d = (objects[j].sum / objects[j].tracks.size() - location).norm();
      if (d < best_distance) best = static_cast<int>(j), best_distance = d;
    }
    if (best < 0) {
      objects.push_back({{}, c, Eigen::Vector3d::Zero()});
      best = static_cast<int>(objects.size()) - 1;
    }
    objects[best].tracks.insert(objects[best].tracks.end(), separate.state.blocks[t].begin(),
                                separate.state.blocks[t].end());
    objects[best].sum += location;
  }
  AssociationState state;
  for (const Object& object : objects) {
    state.blocks.push_back(object.tracks);
    state.classes.push_back(object.class_index);
  }
  state.Canonicalize();
  return state;
}

}  // namespace oslam
