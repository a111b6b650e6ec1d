// Spring bones stepped (spring_sim.hpp).
#include "facecast/rig/spring_sim.hpp"

#include <algorithm>
#include <cmath>

namespace facecast::rig {
namespace {

// The body's turns a fraction `a` of the way from `from` to `to` (the same joints in both, as
// body_turns gives them for one skeleton); `to` when they differ.
JointTurns between(const JointTurns& from, const JointTurns& to, float a) {
  if (from.size() != to.size()) return to;
  JointTurns out = to;
  for (std::size_t i = 0; i < to.size(); ++i) {
    if (from[i].first != to[i].first) return to;
    out[i].second = from[i].second.slerp(a, to[i].second);
  }
  return out;
}

// Moves `tail`, on a rod of `length` from `pivot`, out of a sphere at `centre` of radius `r` (the
// tail's own radius included) to the nearest point that is both on the rod's sphere and outside
// this one: where the two spheres meet. (UniVRM and three-vrm push the tail out from the centre
// and then restore the rod's length, which can put it back in when the sphere lies beyond the
// tail; a tail falling onto a shoulder went through it.) A pivot inside the sphere: pushed
// straight out from the centre, the rod's length restored.
void collide(Eigen::Vector3f& tail, const Eigen::Vector3f& pivot, float length,
             const Eigen::Vector3f& centre, float r) {
  const Eigen::Vector3f d = tail - centre;
  const float n = d.norm();
  if (n >= r || n < 1e-9f) return;
  const Eigen::Vector3f axis = centre - pivot;
  const float dist = axis.norm();
  if (dist <= r || dist < 1e-9f) {
    tail = centre + d * (r / n);
    const Eigen::Vector3f rod = tail - pivot;
    if (rod.norm() > 1e-9f) tail = pivot + rod * (length / rod.norm());
    return;
  }
  // The circle where the spheres meet: along the axis at x from the pivot, of radius rho.
  const Eigen::Vector3f u = axis / dist;
  const float x = (length * length - r * r + dist * dist) / (2 * dist);
  const float rho = std::sqrt(std::max(0.0f, length * length - x * x));
  Eigen::Vector3f side = (tail - pivot) - u * u.dot(tail - pivot);
  if (side.norm() < 1e-9f) side = u.unitOrthogonal();
  tail = pivot + u * x + side.normalized() * rho;
}
}  // namespace

SpringSim::SpringSim(const Skeleton& s, BodyJoints joints)
    : s_(s), joints_(std::move(joints)), step_(1.0 / body_options().spring_rate) {
  const std::size_t nj = s_.parent.size();
  if (s_.springs.empty() || s_.rest_origin.size() != nj) return;
  children_.assign(nj, {});
  std::vector<int> roots;
  for (std::size_t j = 0; j < nj; ++j) {
    const int p = s_.parent[j];
    if (p >= 0 && static_cast<std::size_t>(p) < nj)
      children_[static_cast<std::size_t>(p)].push_back(static_cast<int>(j));
    else
      roots.push_back(static_cast<int>(j));
  }
  // Parents first; a joint on a cycle is never reached.
  order_ = roots;
  for (std::size_t i = 0; i < order_.size(); ++i)
    for (const int c : children_[static_cast<std::size_t>(order_[i])]) order_.push_back(c);
  if (order_.size() != nj) {
    order_.clear();
    return;
  }
  for (const auto& spring : s_.springs.springs)
    for (const auto& sj : spring.joints)
      turns_.emplace_back(sj.joint, Eigen::Quaternionf::Identity());
  tails_.resize(turns_.size());
  local_.assign(nj, Eigen::Affine3f::Identity());
  motion_.assign(nj, Eigen::Affine3f::Identity());
}

void SpringSim::compose(const JointTurns& body) {
  std::fill(local_.begin(), local_.end(), Eigen::Affine3f::Identity());
  for (const auto& [joint, q] : body) {
    const Eigen::Vector3f o = s_.rest_origin[static_cast<std::size_t>(joint)];
    local_[static_cast<std::size_t>(joint)] =
        Eigen::Translation3f(o) * q * Eigen::Translation3f(-o);
  }
  for (const int j : order_) {
    const int p = s_.parent[static_cast<std::size_t>(j)];
    motion_[static_cast<std::size_t>(j)] =
        p >= 0 ? motion_[static_cast<std::size_t>(p)] * local_[static_cast<std::size_t>(j)]
               : local_[static_cast<std::size_t>(j)];
  }
}

// The motions of the joints below `joint`, after its own changed.
void SpringSim::refresh_below(int joint) {
  std::vector<int> stack(children_[static_cast<std::size_t>(joint)]);
  while (!stack.empty()) {
    const auto j = static_cast<std::size_t>(stack.back());
    stack.pop_back();
    motion_[j] = motion_[static_cast<std::size_t>(s_.parent[j])] * local_[j];
    stack.insert(stack.end(), children_[j].begin(), children_[j].end());
  }
}

void SpringSim::step(const JointTurns& body, bool first) {
  compose(body);
  const auto h = static_cast<float>(step_);
  std::size_t i = 0;
  for (const auto& spring : s_.springs.springs) {
    for (const auto& sj : spring.joints) {
      const auto j = static_cast<std::size_t>(sj.joint);
      const int p = s_.parent[j];
      const Eigen::Affine3f parent =
          p >= 0 ? motion_[static_cast<std::size_t>(p)] : Eigen::Affine3f::Identity();
      const Eigen::Vector3f origin = s_.rest_origin[j], at = parent * origin;
      const Eigen::Vector3f carried = parent * sj.tail;  // where the parent alone takes the tail
      const float length = (sj.tail - origin).norm();
      Tail& t = tails_[i];
      Eigen::Vector3f next = carried;
      if (!first) {
        next = t.cur + (t.cur - t.prev) * (1 - sj.drag) +
               (carried - at).normalized() * (sj.stiffness * h) +
               sj.gravity_dir * (sj.gravity_power * h);
        const auto keep_length = [&] {
          const Eigen::Vector3f d = next - at;
          next = d.norm() > 1e-9f ? Eigen::Vector3f(at + d * (length / d.norm())) : carried;
        };
        keep_length();
        for (const int c : spring.colliders) {
          const SpringCollider& col = s_.springs.colliders[static_cast<std::size_t>(c)];
          const Eigen::Affine3f m = col.joint >= 0 ? motion_[static_cast<std::size_t>(col.joint)]
                                                   : Eigen::Affine3f::Identity();
          Eigen::Vector3f centre = m * col.offset;
          if (col.capsule) {
            const Eigen::Vector3f b = m * col.tail, ab = b - centre;
            const float l2 = ab.squaredNorm();
            if (l2 > 1e-12f) centre += ab * std::clamp((next - centre).dot(ab) / l2, 0.0f, 1.0f);
          }
          collide(next, at, length, centre, col.radius + sj.hit_radius);
        }
      }
      t.prev = first ? next : t.cur;
      t.cur = next;
      // The turn that points the rod at the tail, in the rest frame under the parent.
      const Eigen::Quaternionf q = Eigen::Quaternionf::FromTwoVectors(
          sj.tail - origin, parent.linear().transpose() * (next - at));
      turns_[i++].second = q;
      local_[j] = Eigen::Translation3f(origin) * q * Eigen::Translation3f(-origin);
      motion_[j] = parent * local_[j];
      refresh_below(sj.joint);
    }
  }
}

const JointTurns& SpringSim::advance(const BodyPose& pose, double time) {
  if (empty()) return turns_;
  JointTurns body = body_turns(joints_, s_, pose);
  if (!started_) {
    step(body, true);
    started_ = true;
    t0_ = last_time_ = time;
    steps_ = 0;
    last_body_ = std::move(body);
    return turns_;
  }
  if (!(time > last_time_)) return turns_;
  const auto target = static_cast<long>(std::floor((time - t0_) / step_ + 1e-6));
  const auto most = static_cast<long>(std::ceil(2.0 / step_));
  steps_ = std::max(steps_, target - most);
  for (; steps_ < target;) {
    ++steps_;
    const double at = t0_ + static_cast<double>(steps_) * step_;
    const auto a =
        static_cast<float>(std::clamp((at - last_time_) / (time - last_time_), 0.0, 1.0));
    step(between(last_body_, body, a), false);
  }
  last_time_ = time;
  last_body_ = std::move(body);
  return turns_;
}

}  // namespace facecast::rig
