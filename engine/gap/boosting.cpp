#include "gap/boosting.hpp"

#include <algorithm>
#include <cmath>
#include <limits>

#include "core/error.hpp"

namespace kneesim::gap {

BinnedFeatures::BinnedFeatures(const std::vector<std::vector<double>>& columns, int max_bins) {
  KNEESIM_CHECK(max_bins >= 2 && max_bins <= 254, "BinnedFeatures: max_bins must be 2..254");
  rows_ = columns.empty() ? 0 : static_cast<int>(columns.front().size());
  bins_.assign(columns.size() * static_cast<size_t>(rows_), 0);
  for (size_t f = 0; f < columns.size(); ++f) {
    const std::vector<double>& c = columns[f];
    KNEESIM_CHECK(static_cast<int>(c.size()) == rows_, "BinnedFeatures: columns of different lengths");
    std::vector<double> v;
    for (double x : c)
      if (std::isfinite(x)) v.push_back(x);
    std::sort(v.begin(), v.end());
    std::vector<double> edges;
    for (int k = 1; k < max_bins && !v.empty(); ++k) {
      const double e = v[std::min(v.size() - 1, static_cast<size_t>(k * v.size() / max_bins))];
      if (e < v.back() && (edges.empty() || e > edges.back())) edges.push_back(e);
    }
    std::vector<std::vector<double>> members(edges.size() + 2);
    for (int i = 0; i < rows_; ++i) {
      std::uint8_t b = 0;
      if (std::isfinite(c[i]))
        b = static_cast<std::uint8_t>(1 + (std::lower_bound(edges.begin(), edges.end(), c[i]) - edges.begin()));
      bins_[f * rows_ + i] = b;
      if (b > 0) members[b].push_back(c[i]);
    }
    std::vector<double> centres(members.size(), std::numeric_limits<double>::quiet_NaN());
    for (size_t b = 1; b < members.size(); ++b) {
      auto& m = members[b];
      if (m.empty()) continue;
      std::nth_element(m.begin(), m.begin() + m.size() / 2, m.end());
      centres[b] = m[m.size() / 2];
    }
    edges_.push_back(std::move(edges));
    centres_.push_back(std::move(centres));
  }
}

int BoostedTrees::grow(const BinnedFeatures& x, const std::vector<double>& r, const std::vector<int>& groups,
                       int n_groups, std::vector<int>& rows, int depth, const BoostingOptions& o) {
  double sum = 0;
  for (int i : rows) sum += r[i];
  const int n = static_cast<int>(rows.size());
  const int me = static_cast<int>(nodes_.size());
  nodes_.push_back(Node{});
  nodes_[me].value = n > 0 ? o.learning_rate * sum / n : 0.0;
  if (depth >= o.depth || n < 2 * o.min_leaf) return me;
  // Best split over features and thresholds: squared-error gain, both sides large enough and
  // holding rows of enough groups.
  double best_gain = 1e-12 * std::max(1.0, sum * sum / std::max(n, 1));
  int best_f = -1, best_t = -1;
  std::vector<double> hs;
  std::vector<int> hn, hg, left_g(n_groups), total_g(n_groups);
  for (int f = 0; f < x.getNumFeatures(); ++f) {
    const int nb = x.getNumBins(f);
    hs.assign(nb, 0.0);
    hn.assign(nb, 0);
    hg.assign(static_cast<size_t>(nb) * n_groups, 0);
    for (int i : rows) {
      const int b = x.getBin(f, i);
      hs[b] += r[i];
      ++hn[b];
      ++hg[static_cast<size_t>(b) * n_groups + groups[i]];
    }
    std::fill(left_g.begin(), left_g.end(), 0);
    std::fill(total_g.begin(), total_g.end(), 0);
    for (int b = 0; b < nb; ++b)
      for (int g = 0; g < n_groups; ++g) total_g[g] += hg[static_cast<size_t>(b) * n_groups + g];
    double sl = 0;
    int nl = 0;
    for (int t = 0; t + 1 < nb; ++t) {
      sl += hs[t];
      nl += hn[t];
      for (int g = 0; g < n_groups; ++g) left_g[g] += hg[static_cast<size_t>(t) * n_groups + g];
      const int nr = n - nl;
      if (hn[t] == 0 || nl < o.min_leaf) continue;
      if (nr < o.min_leaf) break;
      int gl = 0, gr = 0;
      for (int g = 0; g < n_groups; ++g) gl += left_g[g] > 0, gr += total_g[g] - left_g[g] > 0;
      if (gl < o.min_groups || gr < o.min_groups) continue;
      const double sr = sum - sl;
      const double gain = sl * sl / nl + sr * sr / nr - sum * sum / n;
      if (gain > best_gain) best_gain = gain, best_f = f, best_t = t;
    }
  }
  if (best_f < 0) return me;
  gains_[best_f] += best_gain;
  std::vector<int> left, right;
  for (int i : rows) (x.getBin(best_f, i) <= best_t ? left : right).push_back(i);
  const int l = grow(x, r, groups, n_groups, left, depth + 1, o);
  const int rr = grow(x, r, groups, n_groups, right, depth + 1, o);
  nodes_[me].feature = best_f;
  nodes_[me].threshold = best_t;
  nodes_[me].left = l;
  nodes_[me].right = rr;
  return me;
}

BoostedTrees BoostedTrees::fit(const BinnedFeatures& x, const std::vector<double>& y, const std::vector<int>& groups,
                               const std::vector<int>& rows, const BoostingOptions& o) {
  KNEESIM_CHECK(static_cast<int>(y.size()) == x.getNumRows() && groups.size() == y.size(),
                "BoostedTrees::fit: y and groups must have a value per row");
  KNEESIM_CHECK(o.depth >= 1 && o.min_leaf >= 1 && o.rounds >= 0, "BoostedTrees::fit: bad options");
  BoostedTrees m;
  m.gains_.assign(x.getNumFeatures(), 0.0);
  int n_groups = 0;
  for (int i : rows) n_groups = std::max(n_groups, groups[i] + 1);
  std::vector<double> f(y.size(), 0.0), r(y.size(), 0.0);
  for (int k = 0; k < o.rounds; ++k) {
    for (int i : rows) r[i] = y[i] - f[i];
    std::vector<int> work = rows;
    const int root = m.grow(x, r, groups, n_groups, work, 0, o);
    m.roots_.push_back(root);
    for (int i : rows) f[i] += m.walk(x, i, -1, 0, root);
  }
  return m;
}

double BoostedTrees::walk(const BinnedFeatures& x, int i, int f, int bin, int node) const {
  while (nodes_[node].feature >= 0) {
    const Node& nd = nodes_[node];
    const int b = nd.feature == f ? bin : x.getBin(nd.feature, i);
    node = b <= nd.threshold ? nd.left : nd.right;
  }
  return nodes_[node].value;
}

double BoostedTrees::predict(const BinnedFeatures& x, int i) const { return predictWith(x, i, -1, 0); }

double BoostedTrees::predictWith(const BinnedFeatures& x, int i, int f, int bin) const {
  double s = 0;
  for (int root : roots_) s += walk(x, i, f, bin, root);
  return s;
}

}  // namespace kneesim::gap
