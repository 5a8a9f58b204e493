#include "host_sim/model_steps.h"

#include <Eigen/Geometry>
#include <algorithm>
#include <cmath>
#include <limits>
#include <stdexcept>
#include <string>
#include <unordered_map>
#include <unordered_set>

#include "host_sim/chi2.h"
#include "model_geometry.h"

namespace lslam::sim {

namespace {

using namespace geometry;

using KeySet = std::unordered_set<VariableKey, VariableKeyHash>;
template <typename T>
using KeyMap = std::unordered_map<VariableKey, T, VariableKeyHash>;

bool isBetween(FactorKind k) {
  return k == FactorKind::BetweenSE2 || k == FactorKind::BetweenSE3;
}
bool isPosePrior(FactorKind k) {
  return k == FactorKind::PriorSE2 || k == FactorKind::PriorSE3;
}
bool isLandmarkPrior(FactorKind k) {
  return k == FactorKind::PriorPoint2 || k == FactorKind::PriorPoint3;
}
bool isObservation(FactorKind k) {
  return k == FactorKind::PointXY2 || k == FactorKind::RangeBearing2 || k == FactorKind::PointXYZ3;
}

std::string keyText(const VariableKey& k) {
  return std::string(k.role == VariableRole::Pose ? "pose " : "landmark ") + std::to_string(k.id);
}

std::string factorText(const ModelFactor& f) {
  std::string s = factorKindName(f.kind);
  s += arity(f.kind) == 1 ? " on " + keyText(f.first)
                          : " " + keyText(f.first) + " -> " + keyText(f.second);
  return s;
}

// Ids, roles and self-loops of one factor record.
void checkFactor(const ModelDataset& d, const ModelFactor& f) {
  const bool two = arity(f.kind) == 2;
  if (f.first.id < 0 || (two && f.second.id < 0)) {
    throw DatasetError(d.name, f.line, factorText(f) + ": id out of range (negative)");
  }
  const VariableRole want_first =
      isLandmarkPrior(f.kind) ? VariableRole::Landmark : VariableRole::Pose;
  const VariableRole want_second =
      isObservation(f.kind) ? VariableRole::Landmark : VariableRole::Pose;
  if (f.first.role != want_first || (two && f.second.role != want_second)) {
    throw DatasetError(d.name, f.line, factorText(f) + ": variable of the wrong role for its kind");
  }
  if (isBetween(f.kind) && f.first == f.second) {
    throw DatasetError(d.name, f.line, factorText(f) + " links a pose to itself");
  }
}

// Line of the first factor naming `key` in file order, else of its vertex; 0 if neither.
std::size_t firstLineOf(const ModelDataset& d, const VariableKey& key) {
  for (const ModelFactor& f : d.factors) {
    if (f.first == key || (arity(f.kind) == 2 && f.second == key)) return f.line;
  }
  for (const ModelVertex& v : d.vertices) {
    if (v.key == key) return v.line;
  }
  return 0;
}

const Eigen::VectorXd& valueOf(const ModelEstimate& current, const VariableKey& key,
                               VariableKind kind, const ModelFactor& f) {
  const auto it = current.find(key);
  if (it == current.end()) {
    throw std::invalid_argument("initialValue: " + factorText(f) + " (line " +
                                std::to_string(f.line) + ") needs the value of " + keyText(key) +
                                ", which the current estimate lacks");
  }
  if (it->second.size() != parameterCount(kind)) {
    throw std::invalid_argument(
        "initialValue: the value of " + keyText(key) + " has " + std::to_string(it->second.size()) +
        " entries, " + variableKindName(kind) + " needs " + std::to_string(parameterCount(kind)));
  }
  return it->second;
}

void checkMeasurement(const ModelFactor& f) {
  if (f.measurement.size() != measurementSize(f.kind)) {
    throw std::invalid_argument("initialValue: " + factorText(f) + " (line " +
                                std::to_string(f.line) + "): measurement size " +
                                std::to_string(f.measurement.size()));
  }
}

// The kind of pose `key`: from a factor of the step naming it, else its vertex, else the
// dataset's dimension.
VariableKind poseKind(const ModelDataset& d, const ModelStep& step, const VariableKey& key) {
  for (std::size_t i : step.factors) {
    const ModelFactor& f = d.factors[i];
    if (f.first == key) return factorVariableKind(f.kind, 0);
    if (arity(f.kind) == 2 && f.second == key) return factorVariableKind(f.kind, 1);
  }
  for (const ModelVertex& v : d.vertices) {
    if (v.key == key) return v.kind;
  }
  return d.dimension == 3 ? VariableKind::SE3 : VariableKind::SE2;
}

// A prior on a landmark that no factor observes and no vertex declares (most likely a wrong id).
DatasetError unobservedLandmarkPrior(const ModelDataset& d, const ModelFactor& f) {
  return DatasetError(d.name, f.line,
                      factorText(f) + ": the landmark is never observed and no vertex declares it");
}

// File order (model_steps.h, FILE ORDER): the factors as a stream.
class FileOrderSteps {
 public:
  explicit FileOrderSteps(const ModelDataset& d) : d_(d) {}

  std::vector<ModelStep> build() {
    for (std::size_t i = 0; i < d_.factors.size(); ++i) {
      const ModelFactor& f = d_.factors[i];
      checkFactor(d_, f);
      if (isObservation(f.kind)) {
        observation(f);
      } else if (isLandmarkPrior(f.kind)) {
        if (steps_.empty()) steps_.push_back(ModelStep{});  // step 0, until its pose comes
        enterLandmark(f.first);
      } else {
        poseFactor(f);
      }
      steps_.back().factors.push_back(i);
    }
    checkPriorsOn(checkVertices());
    return std::move(steps_);
  }

 private:
  // Every vertex must be a variable a factor introduced (with no pose factor, the first pose
  // vertex is step 0's pose). Returns the declared landmarks.
  KeySet checkVertices() {
    KeySet declared;
    for (const ModelVertex& v : d_.vertices) {
      if (poses_.empty() && v.key.role == VariableRole::Pose) introducePose(v.key.id);
      if (v.key.role == VariableRole::Landmark) declared.insert(v.key);
      const bool known = v.key.role == VariableRole::Pose ? poses_.count(v.key.id) != 0
                                                          : landmarks_.count(v.key) != 0;
      if (!known) throw DatasetError(d_.name, v.line, keyText(v.key) + " (vertex) has no factor");
    }
    return declared;
  }

  // A landmark prior must be on a landmark that is observed or declared (as in online order).
  void checkPriorsOn(const KeySet& declared) const {
    for (const ModelFactor& f : d_.factors) {
      if (isLandmarkPrior(f.kind) && observed_.count(f.first) == 0 &&
          declared.count(f.first) == 0) {
        throw unobservedLandmarkPrior(d_, f);
      }
    }
  }

  // A prior or a between factor: one naming a pose not seen yet starts its step.
  void poseFactor(const ModelFactor& f) {
    std::int64_t a = f.first.id;
    std::int64_t b = isBetween(f.kind) ? f.second.id : a;
    if (poses_.empty() && a != b) introducePose(std::min(a, b));  // the anchor
    if (poses_.count(a) != 0) std::swap(a, b);                    // a: the unknown pose, if any
    if (poses_.count(a) == 0 && poses_.count(b) == 0 && a != b) {
      throw DatasetError(d_.name, f.line,
                         factorText(f) +
                             " introduces two new poses (file order introduces one "
                             "pose per step)");
    }
    if (poses_.count(a) == 0) introducePose(a);
  }

  // An observation joins the current step; its pose must be known, its landmark enters there.
  void observation(const ModelFactor& f) {
    if (poses_.empty()) introducePose(f.first.id);  // the anchor, seeing its first landmarks
    if (poses_.count(f.first.id) == 0) {
      throw DatasetError(d_.name, f.line,
                         factorText(f) +
                             " is seen from a pose no earlier factor introduced (file order "
                             "introduces a pose by a between factor or a prior)");
    }
    enterLandmark(f.second);
    observed_.insert(f.second);
  }

  void introducePose(std::int64_t id) {
    if (steps_.empty() || steps_.back().new_pose.id >= 0) steps_.push_back(ModelStep{});
    steps_.back().new_pose = {VariableRole::Pose, id};
    poses_.insert(id);
  }

  void enterLandmark(const VariableKey& key) {
    if (landmarks_.insert(key).second) steps_.back().new_landmarks.push_back(key);
  }

  const ModelDataset& d_;
  std::vector<ModelStep> steps_;
  std::unordered_set<std::int64_t> poses_;
  KeySet landmarks_;
  KeySet observed_;
};

}  // namespace

std::vector<ModelStep> buildModelSteps(const ModelDataset& d, StepOrder order) {
  if (order == StepOrder::File) return FileOrderSteps(d).build();
  std::vector<ModelStep> steps;
  if (d.vertices.empty() && d.factors.empty()) return steps;

  // The poses, in ascending id order, one step each.
  std::vector<std::int64_t> ids;
  for (const ModelFactor& f : d.factors) {
    checkFactor(d, f);
    if (f.first.role == VariableRole::Pose) ids.push_back(f.first.id);
    if (arity(f.kind) == 2 && f.second.role == VariableRole::Pose) ids.push_back(f.second.id);
  }
  for (const ModelVertex& v : d.vertices) {
    if (v.key.role == VariableRole::Pose) ids.push_back(v.key.id);
  }
  std::sort(ids.begin(), ids.end());
  ids.erase(std::unique(ids.begin(), ids.end()), ids.end());
  std::unordered_map<std::int64_t, std::size_t> step_of;
  step_of.reserve(ids.size());
  for (std::size_t k = 0; k < ids.size(); ++k) step_of.emplace(ids[k], k);
  // A dataset of prior-only landmarks has one step without a pose.
  steps.resize(std::max<std::size_t>(ids.size(), 1));
  for (std::size_t k = 0; k < ids.size(); ++k) steps[k].new_pose = {VariableRole::Pose, ids[k]};

  // The step of every factor but the landmark priors, and each landmark's entry step.
  constexpr std::size_t kNone = std::numeric_limits<std::size_t>::max();
  std::vector<std::size_t> factor_step(d.factors.size(), kNone);
  KeyMap<std::size_t> landmark_step;
  std::vector<char> anchored(ids.size(), 0);  // a between factor to an older pose, or a prior
  for (std::size_t i = 0; i < d.factors.size(); ++i) {
    const ModelFactor& f = d.factors[i];
    if (isBetween(f.kind)) {
      factor_step[i] = step_of.at(std::max(f.first.id, f.second.id));
      anchored[factor_step[i]] = 1;
    } else if (isPosePrior(f.kind)) {
      factor_step[i] = step_of.at(f.first.id);
      anchored[factor_step[i]] = 1;
    } else if (isObservation(f.kind)) {
      factor_step[i] = step_of.at(f.first.id);
      const auto it = landmark_step.emplace(f.second, factor_step[i]).first;
      it->second = std::min(it->second, factor_step[i]);
    }
  }
  for (std::size_t k = 1; k < ids.size(); ++k) {
    if (anchored[k]) continue;
    const VariableKey key{VariableRole::Pose, ids[k]};
    throw DatasetError(d.name, firstLineOf(d, key),
                       keyText(key) +
                           " has no between factor to an older pose and no prior (online order "
                           "introduces poses in ascending id order; previous pose " +
                           std::to_string(ids[k - 1]) + ")");
  }

  // Landmarks without observation: declared ones with a prior enter in step 0.
  KeySet declared;
  for (const ModelVertex& v : d.vertices) {
    if (v.key.role == VariableRole::Landmark) declared.insert(v.key);
  }
  KeySet has_prior;
  for (std::size_t i = 0; i < d.factors.size(); ++i) {
    const ModelFactor& f = d.factors[i];
    if (!isLandmarkPrior(f.kind)) continue;
    has_prior.insert(f.first);
    const auto it = landmark_step.find(f.first);
    if (it != landmark_step.end()) {
      factor_step[i] = it->second;
    } else if (declared.count(f.first) != 0) {
      factor_step[i] = 0;
    } else {
      throw unobservedLandmarkPrior(d, f);
    }
  }
  for (const ModelVertex& v : d.vertices) {
    if (v.key.role == VariableRole::Landmark && landmark_step.count(v.key) == 0 &&
        has_prior.count(v.key) == 0) {
      throw DatasetError(d.name, v.line, keyText(v.key) + " (vertex) has no factor");
    }
  }

  // Factors in file order; landmarks in the order of their first observation.
  KeySet entered;
  for (std::size_t i = 0; i < d.factors.size(); ++i) {
    const ModelFactor& f = d.factors[i];
    ModelStep& s = steps[factor_step[i]];
    s.factors.push_back(i);
    if (isObservation(f.kind) && landmark_step.at(f.second) == factor_step[i] &&
        entered.insert(f.second).second) {
      s.new_landmarks.push_back(f.second);
    }
  }
  for (const ModelVertex& v : d.vertices) {
    if (v.key.role == VariableRole::Landmark && landmark_step.count(v.key) == 0 &&
        entered.insert(v.key).second) {
      steps[0].new_landmarks.push_back(v.key);
    }
  }
  return steps;
}

Eigen::VectorXd initialValue(const ModelDataset& d, const ModelStep& step, const VariableKey& key,
                             const ModelEstimate& current) {
  if (key.role == VariableRole::Pose) {
    if (key != step.new_pose) {
      throw std::invalid_argument("initialValue: " + keyText(key) + " is not the step's new pose");
    }
    for (std::size_t i : step.factors) {
      const ModelFactor& f = d.factors.at(i);
      if (isPosePrior(f.kind) && f.first == key) {
        checkMeasurement(f);
        return f.measurement;
      }
      if (!isBetween(f.kind) || (f.first != key && f.second != key)) continue;
      checkMeasurement(f);
      const bool se3 = f.kind == FactorKind::BetweenSE3;
      const VariableKind kind = se3 ? VariableKind::SE3 : VariableKind::SE2;
      const Eigen::VectorXd& z = f.measurement;
      if (f.second == key) {
        const Eigen::VectorXd& xi = valueOf(current, f.first, kind, f);
        return se3 ? composeSE3(xi, z) : composeSE2(xi, z);
      }
      const Eigen::VectorXd& xj = valueOf(current, f.second, kind, f);
      return se3 ? composeSE3(xj, inverseSE3(z)) : composeSE2(xj, inverseSE2(z));
    }
    // The first pose without prior: its vertex's value (the file's frame), else the origin.
    const VariableKind kind = poseKind(d, step, key);
    for (const ModelVertex& v : d.vertices) {
      if (v.key == key && v.kind == kind && v.value.size() == parameterCount(kind)) return v.value;
    }
    Eigen::VectorXd v = Eigen::VectorXd::Zero(parameterCount(kind));
    if (kind == VariableKind::SE3) v[6] = 1.0;
    return v;
  }

  if (std::find(step.new_landmarks.begin(), step.new_landmarks.end(), key) ==
      step.new_landmarks.end()) {
    throw std::invalid_argument("initialValue: " + keyText(key) +
                                " is not among the step's new landmarks");
  }
  for (std::size_t i : step.factors) {
    const ModelFactor& f = d.factors.at(i);
    if (!isObservation(f.kind) || f.second != key) continue;
    checkMeasurement(f);
    const Eigen::VectorXd& z = f.measurement;
    if (f.kind == FactorKind::PointXYZ3) {
      const Eigen::VectorXd& x = valueOf(current, f.first, VariableKind::SE3, f);
      return Eigen::Vector3d(x.head<3>() + quat(x.data()) * z.head<3>());
    }
    const Eigen::VectorXd& x = valueOf(current, f.first, VariableKind::SE2, f);
    const Eigen::Vector2d local =
        f.kind == FactorKind::RangeBearing2
            ? Eigen::Vector2d(z[0] * std::cos(z[1]), z[0] * std::sin(z[1]))
            : Eigen::Vector2d(z[0], z[1]);
    return Eigen::Vector2d(x.head<2>() + rot2(x[2]) * local);
  }
  for (std::size_t i : step.factors) {
    const ModelFactor& f = d.factors.at(i);
    if (isLandmarkPrior(f.kind) && f.first == key) {
      checkMeasurement(f);
      return f.measurement;
    }
  }
  throw std::invalid_argument("initialValue: " + keyText(key) +
                              " has neither an observation nor a prior in the step");
}

ModelDataset firstSteps(const ModelDataset& d, const std::vector<ModelStep>& steps, std::size_t n) {
  ModelDataset first;
  first.name = d.name;
  first.format = d.format;
  first.convention = d.convention;
  first.dimension = d.dimension;
  std::unordered_set<VariableKey, VariableKeyHash> keys;
  for (std::size_t s = 0; s < n && s < steps.size(); ++s) {
    if (steps[s].new_pose.id >= 0) keys.insert(steps[s].new_pose);
    keys.insert(steps[s].new_landmarks.begin(), steps[s].new_landmarks.end());
    for (const std::size_t k : steps[s].factors) first.factors.push_back(d.factors[k]);
  }
  for (const ModelVertex& v : d.vertices) {
    if (keys.count(v.key) != 0) first.vertices.push_back(v);
  }
  return first;
}

}  // namespace lslam::sim
