// A performance written as FAPs (high level from its channels, low level through the rig's
// basis) and FAPs read back into a rig's weights (bounded least squares near the high level).
#include <Eigen/Dense>
#include <algorithm>
#include <cmath>

#include "facecast/anim/fap.hpp"
#include "facecast/core/error.hpp"
#include "fap_detail.hpp"

namespace facecast::anim {
namespace {

using namespace detail;

// The two largest of `v` (index > 0 when any is above `floor`), as (index, value) pairs.
std::pair<std::pair<int, double>, std::pair<int, double>> two_largest(std::span<const double> v,
                                                                      double floor) {
  std::pair<int, double> a{0, 0}, b{0, 0};
  for (std::size_t i = 1; i < v.size(); ++i) {
    if (v[i] <= floor) continue;
    const std::pair<int, double> c{static_cast<int>(i), v[i]};
    if (c.second > a.second) {
      b = a;
      a = c;
    } else if (c.second > b.second) {
      b = c;
    }
  }
  return {a, b};
}

FapViseme fap_viseme(const Performance& p, const FapTable& table, double t) {
  std::array<double, 15> by_number{};
  const auto channels = p.viseme_channels(t);
  const auto& names = p.viseme_names();
  for (std::size_t i = 0; i < names.size() && i < channels.size(); ++i) {
    const auto it = table.viseme_numbers.find(names[i]);
    if (it == table.viseme_numbers.end())
      throw Error("configs/anim/fap.json: viseme_numbers has no viseme '" + names[i] + "'");
    by_number[static_cast<std::size_t>(it->second)] += channels[i];
  }
  const auto [a, b] = two_largest(by_number, 0.01);
  FapViseme v;
  v.select1 = a.first;
  v.select2 = b.first > 0 ? b.first : a.first;
  v.blend = b.first > 0 ? static_cast<int>(std::lround(63 * a.second / (a.second + b.second))) : 63;
  return v;
}

FapExpression fap_expression(const Performance& p, const FapTable& table, double t) {
  std::array<double, 7> value{};
  for (std::size_t k = 0; k < table.expressions.size(); ++k)
    value[k + 1] = std::clamp<double>(p.expression_value(table.expressions[k], t), 0.0, 1.0);
  const auto [a, b] = two_largest(value, 0.5 / 63);
  FapExpression e;
  e.select1 = a.first;
  e.intensity1 = static_cast<int>(std::lround(63 * a.second));
  e.select2 = b.first;
  e.intensity2 = static_cast<int>(std::lround(63 * b.second));
  return e;
}

// What FAP 1 and 2 ask of the rig through its viseme and expression tables: the viseme pair
// blended, each expression at its intensity, the two mixed per shape by the max rule (as the
// animation chain mixes them).
class HighLevel {
 public:
  HighLevel(const Mapping& mapping, const FapTable& table) : shapes_(mapping.shape_names().size()) {
    const auto& names = mapping.viseme_names(viseme::VisemeSet::kOculus);
    const auto& rows = mapping.visemes(viseme::VisemeSet::kOculus);
    for (std::size_t i = 0; i < names.size(); ++i) {
      const auto it = table.viseme_numbers.find(names[i]);
      if (it != table.viseme_numbers.end())
        visemes_[static_cast<std::size_t>(it->second)] = rows[i];
    }
    for (std::size_t k = 0; k < table.expressions.size(); ++k)
      if (const auto* row = mapping.expression(table.expressions[k])) expressions_[k + 1] = *row;
  }

  void weights(const FapFrame& f, std::span<float> out) const {
    std::vector<float> viseme(shapes_, 0.0f), expression(shapes_, 0.0f);
    const float blend = static_cast<float>(f.viseme.blend) / 63.0f;
    add(visemes_[static_cast<std::size_t>(f.viseme.select1)], blend, viseme);
    add(visemes_[static_cast<std::size_t>(f.viseme.select2)], 1 - blend, viseme);
    add(expressions_[static_cast<std::size_t>(f.expression.select1)],
        static_cast<float>(f.expression.intensity1) / 63.0f, expression);
    add(expressions_[static_cast<std::size_t>(f.expression.select2)],
        static_cast<float>(f.expression.intensity2) / 63.0f, expression);
    for (std::size_t s = 0; s < shapes_; ++s)
      out[s] = std::clamp(std::max(viseme[s], expression[s]), 0.0f, 1.0f);
  }

 private:
  static void add(const std::vector<Mapping::Entry>& row, float scale, std::vector<float>& out) {
    for (const auto& e : row) out[static_cast<std::size_t>(e.shape)] += scale * e.weight;
  }

  std::size_t shapes_;
  std::array<std::vector<Mapping::Entry>, 15> visemes_;
  std::array<std::vector<Mapping::Entry>, 7> expressions_;
};

// min |B_K w - f_K|^2 + lambda |w - prior|^2 over 0 <= w <= 1 (K: the FAPs the file has set so
// far), by an active-set method on the normal equations H w = g: solve for the free weights with
// the others at their bounds, move the ones that leave [0, 1] to their bound, free a bound one
// whose gradient points inside, until nothing changes. K only grows, so H is rebuilt at most once
// per FAP.
class LowLevel {
 public:
  explicit LowLevel(const FapRig& rig)
      : rig_(rig), n_(static_cast<Eigen::Index>(rig.shape_names().size())) {
    double diagonal = 0;
    for (int fap = 3; fap <= kFapCount; ++fap)
      if (rig.measured(fap) && !is_head(fap))
        for (Eigen::Index s = 0; s < n_; ++s) diagonal += std::pow(basis(fap, s), 2);
    lambda_ = rig.table().prior_weight *
              std::max(diagonal / static_cast<double>(std::max<Eigen::Index>(n_, 1)), 1.0);
    rebuild();
  }

  void solve(const FapFrame& f, const std::bitset<kFapCount>& known, std::span<const float> prior,
             std::span<float> out) {
    std::bitset<kFapCount> k = known;
    for (int fap = 1; fap <= kFapCount; ++fap)
      if (fap < 3 || is_head(fap) || !rig_.measured(fap)) k[at(fap)] = false;
    if (k != used_) {
      used_ = k;
      rebuild();
    }
    Eigen::VectorXd g(n_);
    for (Eigen::Index s = 0; s < n_; ++s) g[s] = lambda_ * prior[static_cast<std::size_t>(s)];
    for (int fap = 3; fap <= kFapCount; ++fap)
      if (used_[at(fap)])
        for (Eigen::Index s = 0; s < n_; ++s) g[s] += basis(fap, s) * f.value[at(fap)];
    // state: 0 free, -1 at 0, +1 at 1
    std::vector<int> state(static_cast<std::size_t>(n_), 0);
    Eigen::VectorXd w = Eigen::VectorXd::Zero(n_);
    for (int round = 0; round < 4 * n_ + 4; ++round) {
      std::vector<Eigen::Index> free;
      for (Eigen::Index s = 0; s < n_; ++s) {
        if (state[static_cast<std::size_t>(s)] == 0)
          free.push_back(s);
        else
          w[s] = state[static_cast<std::size_t>(s)] > 0 ? 1.0 : 0.0;
      }
      const auto m = static_cast<Eigen::Index>(free.size());
      Eigen::MatrixXd hf(m, m);
      Eigen::VectorXd rhs(m);
      for (Eigen::Index a = 0; a < m; ++a) {
        rhs[a] = g[free[static_cast<std::size_t>(a)]];
        for (Eigen::Index s = 0; s < n_; ++s)
          if (state[static_cast<std::size_t>(s)] != 0)
            rhs[a] -= h_(free[static_cast<std::size_t>(a)], s) * w[s];
        for (Eigen::Index b = 0; b < m; ++b)
          hf(a, b) = h_(free[static_cast<std::size_t>(a)], free[static_cast<std::size_t>(b)]);
      }
      const Eigen::VectorXd x = hf.ldlt().solve(rhs);
      bool changed = false;
      for (Eigen::Index a = 0; a < m; ++a) {
        const Eigen::Index s = free[static_cast<std::size_t>(a)];
        w[s] = x[a];
        if (x[a] < 0 || x[a] > 1) {
          state[static_cast<std::size_t>(s)] = x[a] < 0 ? -1 : 1;
          changed = true;
        }
      }
      if (changed) continue;
      // Every free weight is inside: free the bound one whose gradient most wants it inside.
      const Eigen::VectorXd gradient = h_ * w - g;
      Eigen::Index release = -1;
      double most = 1e-12;
      for (Eigen::Index s = 0; s < n_; ++s) {
        const int st = state[static_cast<std::size_t>(s)];
        const double pull = st < 0 ? -gradient[s] : st > 0 ? gradient[s] : 0;
        if (pull > most) most = pull, release = s;
      }
      if (release < 0) break;
      state[static_cast<std::size_t>(release)] = 0;
    }
    for (Eigen::Index s = 0; s < n_; ++s)
      out[static_cast<std::size_t>(s)] = static_cast<float>(std::clamp(w[s], 0.0, 1.0));
  }

 private:
  double basis(int fap, Eigen::Index s) const { return rig_.basis(fap, static_cast<int>(s)); }

  void rebuild() {
    h_ = lambda_ * Eigen::MatrixXd::Identity(n_, n_);
    for (int fap = 3; fap <= kFapCount; ++fap) {
      if (!used_[at(fap)]) continue;
      Eigen::VectorXd row(n_);
      for (Eigen::Index s = 0; s < n_; ++s) row[s] = basis(fap, s);
      h_ += row * row.transpose();
    }
  }

  const FapRig& rig_;
  Eigen::Index n_;
  double lambda_ = 1;
  std::bitset<kFapCount> used_;
  Eigen::MatrixXd h_;
};

}  // namespace

FapSequence to_fap(const rig::Motion& m, const FapRig& rig, double fps, std::string name) {
  if (m.shape_names() != rig.shape_names())
    throw Error("fap: the motion's shapes are not the rig's");
  if (!(fps > 0)) throw Error("fap: fps must be positive");
  FapSequence s;
  s.name = std::move(name);
  s.fps = fps;
  const auto frames = static_cast<std::size_t>(std::ceil(m.duration() * fps - 1e-9));
  s.frames.resize(frames);
  std::vector<float> w(m.shape_names().size());
  for (std::size_t f = 0; f < frames; ++f) {
    rig::BodyPose head;
    m.sample(static_cast<double>(f) / fps, w, &head);
    rig.encode(w, head, s.frames[f]);
  }
  return s;
}

FapSequence to_fap(const Performance& p, const FapRig& rig, double fps, std::string name) {
  FapSequence s = to_fap(static_cast<const rig::Motion&>(p), rig, fps, std::move(name));
  for (std::size_t f = 0; f < s.frames.size(); ++f) {
    const double t = static_cast<double>(f) / fps;
    FapFrame& out = s.frames[f];
    out.viseme = fap_viseme(p, rig.table(), t);
    out.expression = fap_expression(p, rig.table(), t);
    out.mask[0] = out.mask[1] = true;
  }
  return s;
}

FapMotion::FapMotion(const FapSequence& sequence, const FapRig& rig, const Mapping& mapping)
    : shapes_(rig.shape_names()),
      fps_(sequence.fps),
      frames_(static_cast<int>(sequence.frames.size())) {
  if (mapping.shape_names() != shapes_) throw Error("fap: the mapping's shapes are not the rig's");
  const std::size_t n = shapes_.size();
  const HighLevel high(mapping, rig.table());
  LowLevel low(rig);
  weights_.resize(static_cast<std::size_t>(frames_) * n);
  head_.resize(static_cast<std::size_t>(frames_));
  std::bitset<kFapCount> known;
  std::vector<float> prior(n), w(n, 0.0f);
  for (int i = 0; i < frames_; ++i) {
    const FapFrame& f = sequence.frames[static_cast<std::size_t>(i)];
    known |= f.mask;
    high.weights(f, prior);
    low.solve(f, known, prior, w);
    std::copy(w.begin(), w.end(), weights_.begin() + static_cast<std::ptrdiff_t>(i * n));
    head_[static_cast<std::size_t>(i)] = {static_cast<float>(f.value[at(kHeadYaw)] * kAu),
                                          static_cast<float>(f.value[at(kHeadPitch)] * kAu),
                                          static_cast<float>(f.value[at(kHeadRoll)] * kAu)};
  }
}

double FapMotion::duration() const {
  return frames_ / fps_;
}

void FapMotion::sample(double t, std::span<float> weights, rig::BodyPose* head) const {
  const std::size_t n = shapes_.size();
  if (weights.size() != n)
    throw Error("fap: " + std::to_string(weights.size()) + " weights for " + std::to_string(n) +
                " shapes");
  if (frames_ == 0) {
    std::fill(weights.begin(), weights.end(), 0.0f);
    if (head) *head = {};
    return;
  }
  const double x = std::clamp(t * fps_, 0.0, static_cast<double>(frames_ - 1));
  const auto i = static_cast<std::size_t>(x);
  const std::size_t j = std::min(i + 1, static_cast<std::size_t>(frames_ - 1));
  const auto a = static_cast<float>(x - static_cast<double>(i));
  for (std::size_t s = 0; s < n; ++s)
    weights[s] = (1 - a) * weights_[i * n + s] + a * weights_[j * n + s];
  if (head) {
    const auto& h0 = head_[i];
    const auto& h1 = head_[j];
    *head = {(1 - a) * h0.yaw + a * h1.yaw, (1 - a) * h0.pitch + a * h1.pitch,
             (1 - a) * h0.roll + a * h1.roll};
  }
}

}  // namespace facecast::anim
