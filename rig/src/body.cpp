// The body's joints and their turns (body.hpp).
#include "facecast/rig/body.hpp"

#include <algorithm>
#include <cmath>
#include <map>

#include "facecast/core/config.hpp"
#include "facecast/core/config_reader.hpp"
#include "facecast/core/error.hpp"
#include "facecast/rig/rest_pose.hpp"

namespace facecast::rig {
namespace {

constexpr float kDegree = 3.14159265f / 180.0f;

int parent_of(const Skeleton& s, int j) {
  return j >= 0 && static_cast<std::size_t>(j) < s.parent.size()
             ? s.parent[static_cast<std::size_t>(j)]
             : -1;
}

// How many levels of joints hang below j, counted up to `limit`.
int depth_below(const std::vector<std::vector<int>>& children, int j, int limit) {
  if (limit == 0) return 0;
  int deepest = 0;
  for (const int c : children[static_cast<std::size_t>(j)])
    deepest = std::max(deepest, 1 + depth_below(children, c, limit - 1));
  return deepest;
}

// The spine: from the chest's parent down to the hips (excluded), lowest first. The hips are the
// VRM humanoid's, else the first joint down that another limb (a branch two or more joints deep)
// leaves from; a root reached without one is taken for the hips.
std::vector<int> find_spine(const Skeleton& s, int chest) {
  const std::size_t nj = s.parent.size();
  std::vector<std::vector<int>> children(nj);
  for (std::size_t j = 0; j < nj; ++j)
    if (s.parent[j] >= 0 && static_cast<std::size_t>(s.parent[j]) < nj)
      children[static_cast<std::size_t>(s.parent[j])].push_back(static_cast<int>(j));
  const int hips = s.humanoid_bone("hips");
  std::vector<int> spine;
  for (int from = chest, j = parent_of(s, chest); j >= 0 && spine.size() < nj;
       from = j, j = parent_of(s, j)) {
    if (j == hips || parent_of(s, j) < 0) break;
    const auto& c = children[static_cast<std::size_t>(j)];
    const bool limb = hips < 0 && std::any_of(c.begin(), c.end(), [&](int k) {
                        return k != from && depth_below(children, k, 2) >= 1;
                      });
    if (limb) break;
    spine.push_back(j);
  }
  std::reverse(spine.begin(), spine.end());
  return spine;
}

Eigen::Quaternionf about(const Eigen::Vector3f& axis, float radians) {
  return Eigen::Quaternionf(Eigen::AngleAxisf(radians, axis));
}

}  // namespace

const BodyOptions& body_options() {
  static const BodyOptions options = [] {
    BodyOptions o;
    ConfigReader c = ConfigReader::open(config_path("rig/body.json"));
    c.read("neck_share", o.neck_share)
        .read("breath_chest_deg", o.breath_chest_deg)
        .read("breath_shoulder_deg", o.breath_shoulder_deg)
        .read("shrug_deg", o.shrug_deg)
        .read("lean_counter", o.lean_counter)
        .read("spring_rate", o.spring_rate)
        .reject_unknown();
    if (!(o.spring_rate >= 10 && o.spring_rate <= 480))
      c.fail("spring_rate", "must be in [10, 480] steps per second");
    if (!(o.neck_share >= 0 && o.neck_share <= 1)) c.fail("neck_share", "must be in [0, 1]");
    if (!(o.lean_counter >= 0 && o.lean_counter <= 1)) c.fail("lean_counter", "must be in [0, 1]");
    for (const float deg : {o.breath_chest_deg, o.breath_shoulder_deg, o.shrug_deg})
      if (!(std::abs(deg) <= 30)) c.fail("breath_chest_deg", "angles must be within 30 degrees");
    return o;
  }();
  return options;
}

std::vector<int> BodyJoints::all() const {
  std::vector<int> out{head, neck, chest, shoulder[0], shoulder[1], upper_arm[0], upper_arm[1]};
  out.insert(out.end(), spine.begin(), spine.end());
  std::erase(out, -1);
  std::sort(out.begin(), out.end());
  out.erase(std::unique(out.begin(), out.end()), out.end());
  return out;
}

BodyJoints find_body_joints(const Skeleton& s) {
  BodyJoints b;
  if (s.parent.size() != s.joint_names.size() || s.rest_origin.size() != s.parent.size()) return b;
  b.head = humanoid_joint(s, "head");
  if (b.head < 0) return b;
  b.neck = humanoid_joint(s, "neck");
  // A neck that does not carry the head is not one.
  bool carries = false;
  for (int j = parent_of(s, b.head), guard = 0; j >= 0 && guard < 1000;
       j = parent_of(s, j), ++guard)
    carries |= j == b.neck;
  if (!carries) b.neck = -1;
  const int top = b.neck >= 0 ? b.neck : b.head;
  b.chest = s.humanoid_bone("upperChest");
  if (b.chest < 0) b.chest = s.humanoid_bone("chest");
  if (b.chest < 0 || b.chest == top) b.chest = parent_of(s, top);
  // A chest that is the skeleton's root would turn the whole figure, legs and all.
  if (parent_of(s, b.chest) < 0) b.chest = -1;
  if (b.chest < 0) return b;
  b.spine = find_spine(s, b.chest);
  const char* arms[2] = {"leftUpperArm", "rightUpperArm"};
  const char* shoulders[2] = {"leftShoulder", "rightShoulder"};
  for (int side = 0; side < 2; ++side) {
    b.upper_arm[side] = humanoid_joint(s, arms[side]);
    int sh = s.humanoid_bone(shoulders[side]);
    if (sh < 0) sh = parent_of(s, b.upper_arm[side]);
    const bool on_trunk =
        sh == b.chest || std::find(b.spine.begin(), b.spine.end(), sh) != b.spine.end();
    if (sh >= 0 && !on_trunk) b.shoulder[side] = sh;
  }
  return b;
}

JointTurns body_turns(const BodyJoints& b, const Skeleton& s, const BodyPose& pose,
                      const BodyOptions& o) {
  std::map<int, Eigen::Quaternionf> turn;
  const auto add = [&](int joint, const Eigen::Quaternionf& q) {
    if (joint < 0) return;
    const auto [it, inserted] = turn.try_emplace(joint, q);
    if (!inserted) it->second = it->second * q;
  };
  const Eigen::Vector3f x = Eigen::Vector3f::UnitX(), y = Eigen::Vector3f::UnitY(),
                        z = Eigen::Vector3f::UnitZ();
  // The head's rotation (yaw, then pitch, then roll), shared by the neck and the head.
  const auto head_turn = [&](float share) {
    return about(z, share * pose.roll) * about(x, share * pose.pitch) * about(y, share * pose.yaw);
  };
  if (b.neck >= 0) {
    add(b.neck, head_turn(o.neck_share));
    add(b.head, head_turn(1 - o.neck_share));
  } else {
    add(b.head, head_turn(1));
  }
  if (b.chest < 0) return {turn.begin(), turn.end()};
  const int top = b.neck >= 0 ? b.neck : b.head;
  // Breath: the chest pitched back, the neck keeping the head's direction.
  const float chest = pose.breath * o.breath_chest_deg * kDegree;
  add(b.chest, about(x, -chest));
  add(top, about(x, chest));
  // Lean (+: to the figure's left, +X: a turn about -Z), spread over the spine;
  // the chest (or, leaning itself, the neck) turns part of it back.
  if (!b.spine.empty()) {
    for (const int j : b.spine) add(j, about(z, -pose.lean / static_cast<float>(b.spine.size())));
    add(b.chest, about(z, o.lean_counter * pose.lean));
  } else {
    add(b.chest, about(z, -pose.lean));
    add(top, about(z, o.lean_counter * pose.lean));
  }
  // Shoulders raised (each toward its own side), the upper arms
  // turned back so that the arms rise without swinging out.
  const float raise = (pose.breath * o.breath_shoulder_deg + pose.shrug * o.shrug_deg) * kDegree;
  const Eigen::Vector3f centre = s.rest_origin[static_cast<std::size_t>(b.chest)];
  for (int side = 0; side < 2; ++side) {
    const int sh = b.shoulder[side];
    if (sh < 0) continue;
    const int tip = b.upper_arm[side] >= 0 ? b.upper_arm[side] : sh;
    const float dx = s.rest_origin[static_cast<std::size_t>(tip)].x() - centre.x();
    const float sign = dx != 0 ? (dx > 0 ? 1.0f : -1.0f) : (side == 0 ? 1.0f : -1.0f);
    add(sh, about(z, sign * raise));
    if (b.upper_arm[side] >= 0) add(b.upper_arm[side], about(z, -sign * raise));
  }
  return {turn.begin(), turn.end()};
}

std::vector<Eigen::Affine3f> compose_turns(const Skeleton& s, const JointTurns& turns,
                                           std::vector<char>* moved_out) {
  const std::size_t nj = s.parent.size();
  std::vector<Eigen::Affine3f> local(nj, Eigen::Affine3f::Identity());
  std::vector<char> turned(nj, 0);
  for (const auto& [joint, q] : turns) {
    const auto j = static_cast<std::size_t>(joint);
    const Eigen::Vector3f o = s.rest_origin[j];
    local[j] = Eigen::Translation3f(o) * q * Eigen::Translation3f(-o);
    turned[j] = !q.isApprox(Eigen::Quaternionf::Identity(), 0.0f);
  }
  std::vector<Eigen::Affine3f> motion(nj, Eigen::Affine3f::Identity());
  std::vector<char> moved(nj, 0), done(nj, 0);
  std::vector<std::size_t> chain;
  for (std::size_t j = 0; j < nj; ++j) {
    // The chain up to a joint already composed (or a root), then down it.
    chain.assign(1, j);
    while (!done[chain.back()] && s.parent[chain.back()] >= 0 && chain.size() <= nj)
      chain.push_back(static_cast<std::size_t>(s.parent[chain.back()]));
    if (chain.size() > nj) throw Error("skeleton: the joints' parents form a cycle");
    for (auto it = chain.rbegin(); it != chain.rend(); ++it) {
      if (done[*it]) continue;
      const int p = s.parent[*it];
      const bool from_parent = p >= 0 && moved[static_cast<std::size_t>(p)];
      if (from_parent)
        motion[*it] = motion[static_cast<std::size_t>(p)] * local[*it];
      else if (turned[*it])
        motion[*it] = local[*it];
      moved[*it] = from_parent || turned[*it];
      done[*it] = 1;
    }
  }
  if (moved_out) *moved_out = std::move(moved);
  return motion;
}

}  // namespace facecast::rig
