#pragma once
// A small gradient-boosted regression-tree learner for the gap diagnosis's model-agnostic check
// (gap/remaining.hpp): squared loss, shallow trees on quantile-binned features, missing values in a
// bin of their own, and leaves that must hold frames of at least two groups (cycles), so a tree cannot
// spend a leaf on one cycle's noise.
//
// Why boosted trees rather than ridge on a spline basis: the structures a knee force can leave are
// steps (the sign of the flexion rate), thresholds (a load beyond which something engages) and
// products of two signals (a load through a flexion-dependent lever); depth-2 trees model all three
// without enumerating products or knots, choose the few signals that matter out of dozens, and give
// each signal's share of the fit (split gains) and partial dependence directly. Cost is linear in
// frames x features.

#include <cstdint>
#include <string>
#include <vector>

namespace kneesim::gap {

/// Features binned at their quantiles: value bins 1..k (k <= max_bins), bin 0 for missing (NaN).
class BinnedFeatures {
 public:
  /// @p columns[f][i]: feature f of row i (all columns the same length); at most 255 bins.
  BinnedFeatures(const std::vector<std::vector<double>>& columns, int max_bins);
  int getNumRows() const { return rows_; }
  int getNumFeatures() const { return static_cast<int>(edges_.size()); }
  /// Bin of row @p i in feature @p f.
  std::uint8_t getBin(int f, int i) const { return bins_[static_cast<size_t>(f) * rows_ + i]; }
  /// Number of bins of feature @p f, the missing bin included.
  int getNumBins(int f) const { return static_cast<int>(edges_[f].size()) + 2; }
  /// A representative value of bin @p b of feature @p f (the median of its rows; NaN for bin 0).
  double getBinValue(int f, int b) const { return centres_[f][b]; }

 private:
  int rows_ = 0;
  std::vector<std::vector<double>> edges_;    // upper edges of bins 1..k-1
  std::vector<std::vector<double>> centres_;  // per bin (index 0: NaN)
  std::vector<std::uint8_t> bins_;            // feature-major
};

/// Settings of BoostedTrees::fit.
struct BoostingOptions {
  int rounds = 50;             ///< Trees.
  double learning_rate = 0.1;  ///< Each tree's leaves are scaled by this.
  int depth = 2;               ///< 1 (stumps: additive) or 2 (pairwise interactions).
  int min_leaf = 10;           ///< Rows a leaf must hold.
  int min_groups = 2;          ///< Distinct groups (cycles) a leaf must hold rows of.
};

/// An additive model of trees on binned features, fitted by least-squares gradient boosting.
class BoostedTrees {
 public:
  /// Fits @p y on the rows @p rows of @p x (groups[i] is row i's cycle, 0-based).
  static BoostedTrees fit(const BinnedFeatures& x, const std::vector<double>& y, const std::vector<int>& groups,
                          const std::vector<int>& rows, const BoostingOptions& options);
  /// The prediction at row @p i of @p x (any row, fitted or not).
  double predict(const BinnedFeatures& x, int i) const;
  /// The prediction at row @p i with feature @p f's bin replaced by @p bin (partial dependence).
  double predictWith(const BinnedFeatures& x, int i, int f, int bin) const;
  /// Per feature, the total reduction of the squared error its splits made over all trees.
  const std::vector<double>& getGains() const { return gains_; }
  int getNumTrees() const { return static_cast<int>(roots_.size()); }

 private:
  struct Node {
    int feature = -1;           // -1: leaf
    int threshold = 0;          // rows with bin <= threshold go left
    int left = -1, right = -1;  // children (indices into nodes_)
    double value = 0;           // leaf output (learning rate applied)
  };
  double walk(const BinnedFeatures& x, int i, int f, int bin, int node) const;
  int grow(const BinnedFeatures& x, const std::vector<double>& r, const std::vector<int>& groups, int n_groups,
           std::vector<int>& rows, int depth, const BoostingOptions& o);
  std::vector<Node> nodes_;
  std::vector<int> roots_;
  std::vector<double> gains_;
};

}  // namespace kneesim::gap
