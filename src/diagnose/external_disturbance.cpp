#include "alphainv/diagnose/external_disturbance.hpp"

#include <algorithm>
#include <cmath>

#include <Eigen/Dense>

#include "alphainv/error.hpp"
#include "alphainv/model/detail/field_checks.hpp"

namespace alphainv {

namespace {

constexpr double kNaN = std::numeric_limits<double>::quiet_NaN();

double median(std::vector<double> x) {
  if (x.empty()) return kNaN;
  const std::size_t h = x.size() / 2;
  std::nth_element(x.begin(), x.begin() + static_cast<std::ptrdiff_t>(h), x.end());
  return x[h];
}

/// One window of the means: samples [first, last) of the run, its mean over the judged ones.
struct Window {
  std::size_t first = 0, last = 0;
  double mean = kNaN;  ///< NaN: fewer than half its samples judged
  /// Half its samples valid or more, but fewer than half judged (positions not repeated): a pulse
  /// may go on through it (locate_once()).
  bool unjudged = false;
};

/// The split s in [lo, hi] (sample indices) that maximises Σ_{k ∈ [s, pivot)} w_k when
/// `rising` (the interval starts at s) or Σ_{k ∈ [pivot, s)} w_k otherwise (it ends at s), with
/// w_k = sign·(n̂_k − baseline − level/2): the least-squares position of a step's edge.
std::size_t refine_edge(const std::vector<double>& n, const std::vector<bool>& valid, double baseline,
                        double level, std::size_t lo, std::size_t hi, std::size_t pivot, bool rising) {
  const double sign = level >= 0.0 ? 1.0 : -1.0;
  auto w = [&](std::size_t k) {
    return valid[k] ? sign * (n[k] - baseline - 0.5 * level) : 0.0;
  };
  std::size_t best = rising ? lo : hi;
  double best_sum = -std::numeric_limits<double>::infinity();
  if (rising) {  // Σ_{k=s}^{pivot−1} w_k for s from pivot down to lo
    double sum = 0.0;
    for (std::size_t s = pivot; s-- > lo;) {
      sum += w(s);
      if (sum > best_sum) best_sum = sum, best = s;
    }
  } else {  // Σ_{k=pivot}^{s−1} w_k for s from pivot up to hi
    double sum = 0.0;
    for (std::size_t s = pivot; s < hi; ++s) {
      sum += w(s);
      if (sum > best_sum) best_sum = sum, best = s + 1;
    }
  }
  return best;
}

}  // namespace

void DisturbanceOptions::validate() const {
  detail::require_positive("window_s", window_s);
  detail::require_positive("threshold", threshold);
  if (!(max_active_share > 0.0 && max_active_share <= 1.0)) {
    detail::bad("max_active_share", "a share in (0, 1]", max_active_share);
  }
  detail::require_nonnegative("min_interval_s", min_interval_s);
  detail::require_nonnegative("reference_period_s", reference_period_s);
}

namespace {

/// n − (the least-squares fit of n on `basis` and a constant over the samples `use`).
std::vector<double> state_remainder(const std::vector<double>& n, const std::vector<bool>& use,
                                    const std::vector<std::vector<double>>& basis) {
  if (basis.empty()) return n;
  std::vector<std::size_t> rows;
  for (std::size_t k = 0; k < n.size(); ++k) {
    if (use[k]) rows.push_back(k);
  }
  const auto p = static_cast<Eigen::Index>(basis.size() + 1);
  if (rows.size() < static_cast<std::size_t>(4 * p)) return n;
  Eigen::MatrixXd x(static_cast<Eigen::Index>(rows.size()), p);
  Eigen::VectorXd y(static_cast<Eigen::Index>(rows.size()));
  for (std::size_t i = 0; i < rows.size(); ++i) {
    const auto r = static_cast<Eigen::Index>(i);
    x(r, 0) = 1.0;
    for (std::size_t j = 0; j < basis.size(); ++j) x(r, static_cast<Eigen::Index>(j + 1)) = basis[j][rows[i]];
    y(r) = n[rows[i]];
  }
  const Eigen::VectorXd b = x.colPivHouseholderQr().solve(y);
  std::vector<double> out(n.size());
  for (std::size_t k = 0; k < n.size(); ++k) {
    double f = b(0);
    for (std::size_t j = 0; j < basis.size(); ++j) f += b(static_cast<Eigen::Index>(j + 1)) * basis[j][k];
    out[k] = n[k] - f;
  }
  return out;
}

/// `n` less its part periodic with `period_s` (header: the median over the cycles of the samples
/// `use` at each phase bin of width `bin_s`); `n` itself when the samples `use` span fewer than
/// kMinPeriodicCycles cycles or period_s is 0.
std::vector<double> without_periodic_part(const std::vector<double>& t, const std::vector<double>& n,
                                          const std::vector<bool>& use, double period_s,
                                          double bin_s) {
  if (!(period_s > 0.0) || t.empty()) return n;
  double first = std::numeric_limits<double>::infinity(), last = -first;
  for (std::size_t k = 0; k < t.size(); ++k) {
    if (use[k]) first = std::min(first, t[k]), last = std::max(last, t[k]);
  }
  if (!(last - first >= DisturbanceOptions::kMinPeriodicCycles * period_s)) return n;
  const auto bins = static_cast<std::size_t>(std::max(8.0, std::round(period_s / bin_s)));
  const auto bin_of = [&](double tk) {
    const double phase = std::fmod(tk - t.front(), period_s) / period_s;  // [0, 1)
    return std::min(bins - 1, static_cast<std::size_t>(phase * static_cast<double>(bins)));
  };
  std::vector<std::vector<double>> at(bins);
  for (std::size_t k = 0; k < t.size(); ++k) {
    if (use[k]) at[bin_of(t[k])].push_back(n[k]);
  }
  std::vector<double> med(bins, 0.0);
  for (std::size_t b = 0; b < bins; ++b) {
    if (!at[b].empty()) med[b] = median(at[b]);
  }
  std::vector<double> out(n.size());
  for (std::size_t k = 0; k < n.size(); ++k) out[k] = n[k] - med[bin_of(t[k])];
  return out;
}

/// `n` less its part that is a function of `x` (header, "What the position explains"): the
/// median over the passes through each of kPositionBins bins of x's range (over `use`; a pass
/// ends when x has been out of the bin for more than gap_s) of the passes' means of n, where a
/// bin has kMinPositionPasses passes or more; the samples of the other bins (and outside the
/// range) are cleared in `*judged` when given (a torque of position there cannot be told from
/// one of time). `n` itself when x is empty or its range is 0.
std::vector<double> without_position_part(const std::vector<double>& t, const std::vector<double>& x,
                                          const std::vector<double>& n, const std::vector<bool>& use,
                                          double gap_s, std::vector<bool>* judged) {
  if (x.empty()) return n;
  double lo = std::numeric_limits<double>::infinity(), hi = -lo;
  for (std::size_t k = 0; k < x.size(); ++k) {
    if (use[k]) lo = std::min(lo, x[k]), hi = std::max(hi, x[k]);
  }
  if (!(hi > lo)) return n;
  const std::size_t bins = DisturbanceOptions::kPositionBins;
  const double width = (hi - lo) / static_cast<double>(bins);
  const auto bin_of = [&](double xk) -> std::size_t {
    if (!(xk >= lo && xk <= hi)) return bins;  // outside the range (or NaN): none
    return std::min(bins - 1, static_cast<std::size_t>((xk - lo) / width));
  };
  // The passes' means per bin: a pass is the bin's samples until the joint has been away from it
  // longer than `gap_s` (a jitter across a bin's edge is not a new pass, a return is).
  struct Pass {
    double sum = 0.0, last_s = 0.0;
    std::size_t m = 0;
  };
  std::vector<std::vector<Pass>> passes(bins);
  for (std::size_t k = 0; k < x.size(); ++k) {
    const std::size_t b = use[k] ? bin_of(x[k]) : bins;
    if (b == bins) continue;
    std::vector<Pass>& p = passes[b];
    if (p.empty() || t[k] - p.back().last_s > gap_s) p.emplace_back();
    p.back().sum += n[k], ++p.back().m, p.back().last_s = t[k];
  }
  std::vector<double> med(bins, kNaN);
  for (std::size_t b = 0; b < bins; ++b) {
    if (passes[b].size() < DisturbanceOptions::kMinPositionPasses) continue;
    std::vector<double> means;
    for (const Pass& p : passes[b]) means.push_back(p.sum / static_cast<double>(p.m));
    med[b] = median(std::move(means));
  }
  std::vector<double> out(n);
  for (std::size_t k = 0; k < x.size(); ++k) {
    const std::size_t b = bin_of(x[k]);
    if (b < bins && std::isfinite(med[b])) {
      out[k] -= med[b];
    } else if (judged != nullptr) {
      (*judged)[k] = false;
    }
  }
  return out;
}

/// One pass of the location on `n` (the file comment of the header, after the state fit): the
/// windows' means over the samples `judged` (a subset of `valid`: those of positions not repeated
/// left out), an interval's edges and level over the samples `valid` (a pulse that pushes the
/// joint where it has not been is located whole).
DisturbanceEstimate locate_once(const std::vector<double>& t, const std::vector<double>& n,
                                const std::vector<bool>& valid, const std::vector<bool>& judged,
                                const DisturbanceOptions& o);

/// Sets aside the intervals of `d` that have a neighbour of the opposite sign half a reference
/// period away (within DisturbanceOptions::kHalfPeriodTolerance of it): the model's misfit along
/// a periodic reference, mirrored in each half cycle (header comment). period_s 0: nothing.
void set_aside_half_period_pairs(const std::vector<double>& t, double period_s, DisturbanceEstimate& d) {
  if (!(period_s > 0.0) || d.intervals.size() < 2) return;
  const double half = 0.5 * period_s;
  std::vector<bool> paired(d.intervals.size(), false);
  const auto centre = [](const DisturbanceInterval& iv) { return 0.5 * (iv.start_s + iv.end_s); };
  for (std::size_t i = 0; i < d.intervals.size(); ++i) {
    for (std::size_t j = i + 1; j < d.intervals.size(); ++j) {
      const double gap = centre(d.intervals[j]) - centre(d.intervals[i]);
      if (std::abs(gap - half) <= DisturbanceOptions::kHalfPeriodTolerance * half &&
          d.intervals[i].level_v * d.intervals[j].level_v < 0.0) {
        paired[i] = paired[j] = true;
      }
    }
  }
  std::vector<DisturbanceInterval> kept;
  std::size_t set_aside = 0;
  for (std::size_t i = 0; i < d.intervals.size(); ++i) {
    if (!paired[i]) {
      kept.push_back(d.intervals[i]);
      continue;
    }
    ++set_aside;
    for (std::size_t k = 0; k < t.size(); ++k) {
      if (t[k] >= d.intervals[i].start_s && t[k] < d.intervals[i].end_s) d.d_v[k] = 0.0;
    }
  }
  if (set_aside == 0) return;
  d.intervals = std::move(kept);
  d.half_period_pairs_set_aside = set_aside;
  double ss = 0.0;
  for (double v : d.d_v) ss += v * v;
  d.rms_v = d.d_v.empty() ? 0.0 : std::sqrt(ss / static_cast<double>(d.d_v.size()));
  const std::string why = std::to_string(set_aside) +
                          " interval(s) set aside: each with one of the opposite sign half a reference "
                          "period away (the model's misfit along the reference, not a torque of time)";
  d.message = d.intervals.empty() ? why : (d.message.empty() ? why : d.message + "; " + why);
}

}  // namespace

DisturbanceEstimate locate_disturbance(const std::vector<double>& t, const std::vector<double>& n,
                                       const std::vector<bool>& valid_in,
                                       const DisturbanceOptions& o,
                                       const std::vector<std::vector<double>>& basis,
                                       const std::vector<double>& position) {
  o.validate();
  if (!position.empty() && position.size() != t.size()) {
    throw Error("expected as many values as times (" + std::to_string(t.size()) + "), found " +
                    std::to_string(position.size()),
                {}, 0, "position_rad");
  }
  for (std::size_t j = 0; j < basis.size(); ++j) {
    if (basis[j].size() != t.size()) {
      throw Error("expected as many values as times (" + std::to_string(t.size()) + "), found " +
                      std::to_string(basis[j].size()),
                  {}, 0, "state_basis[" + std::to_string(j) + "]");
    }
  }
  if (n.size() != t.size()) {
    throw Error("expected as many values as times (" + std::to_string(t.size()) + "), found " +
                    std::to_string(n.size()),
                {}, 0, "n_hat_v");
  }
  if (!valid_in.empty() && valid_in.size() != t.size()) {
    throw Error("expected as many flags as times (" + std::to_string(t.size()) + "), found " +
                    std::to_string(valid_in.size()),
                {}, 0, "valid");
  }
  std::vector<bool> valid = valid_in.empty() ? std::vector<bool>(t.size(), true) : valid_in;
  for (std::size_t k = 0; k < n.size(); ++k) valid[k] = valid[k] && std::isfinite(n[k]);
  for (const auto& col : basis) {
    for (std::size_t k = 0; k < n.size(); ++k) valid[k] = valid[k] && std::isfinite(col[k]);
  }
  const double bin_s = o.window_s / 5.0;
  // The state's part, then (where it narrows the spread) the position's, then the reference's
  // (header comment). `located`: the samples judged (those of positions not repeated left out).
  const double gap_s = 0.5 * o.window_s;
  const std::vector<double> state_rest = state_remainder(n, valid, basis);
  std::vector<bool> located = valid;
  DisturbanceEstimate d = locate_once(
      t, without_periodic_part(t, state_rest, valid, o.reference_period_s, bin_s), valid, located, o);
  bool with_position = false;
  if (!position.empty()) {
    std::vector<bool> located_p = valid;
    const std::vector<double> r = without_periodic_part(
        t, without_position_part(t, position, state_rest, valid, gap_s, &located_p), valid,
        o.reference_period_s, bin_s);
    const auto count = [](const std::vector<bool>& f) {
      return static_cast<double>(std::count(f.begin(), f.end(), true));
    };
    if (count(located_p) >= DisturbanceOptions::kMinPositionShare * count(valid)) {
      DisturbanceEstimate dp = locate_once(t, r, valid, located_p, o);
      if (dp.ok && (!d.ok || dp.spread_v <= DisturbanceOptions::kPositionSpreadGain * d.spread_v)) {
        d = std::move(dp);
        located = std::move(located_p);
        with_position = true;
      }
    }
  }
  d.position_part_removed = with_position;
  if ((basis.empty() && !with_position && !(o.reference_period_s > 0.0)) || d.intervals.empty()) {
    set_aside_half_period_pairs(t, o.reference_period_s, d);
    return d;
  }
  // Again with the state (and the position's and periodic parts) fitted without the intervals'
  // samples (the pulses do not bend it), on the samples judged the first time.
  std::vector<bool> use = valid;
  for (std::size_t k = 0; k < t.size(); ++k) use[k] = use[k] && d.d_v[k] == 0.0;
  std::vector<double> rest = state_remainder(n, use, basis);
  if (with_position) rest = without_position_part(t, position, rest, use, gap_s, nullptr);
  DisturbanceEstimate again = locate_once(
      t, without_periodic_part(t, rest, use, o.reference_period_s, bin_s), valid, located, o);
  again.position_part_removed = with_position;
  set_aside_half_period_pairs(t, o.reference_period_s, again);
  return again;
}

namespace {

DisturbanceEstimate locate_once(const std::vector<double>& t, const std::vector<double>& n,
                                const std::vector<bool>& valid, const std::vector<bool>& judged,
                                const DisturbanceOptions& o) {
  DisturbanceEstimate out;
  out.d_v.assign(t.size(), 0.0);

  // The windows and their means.
  std::vector<Window> win;
  for (std::size_t k = 0; k < t.size();) {
    Window w;
    w.first = k;
    const double end = t[k] + o.window_s;
    double s = 0.0;
    std::size_t m = 0, m_valid = 0;
    while (k < t.size() && t[k] < end) {
      if (judged[k]) s += n[k], ++m;
      if (valid[k]) ++m_valid;
      ++k;
    }
    w.last = k;
    if (2 * m >= w.last - w.first && m > 0) w.mean = s / static_cast<double>(m);
    w.unjudged = !std::isfinite(w.mean) && 2 * m_valid >= w.last - w.first && m_valid > 0;
    win.push_back(w);
  }
  std::vector<double> means;
  for (const Window& w : win) {
    if (std::isfinite(w.mean)) means.push_back(w.mean);
  }
  out.windows = means.size();
  if (means.size() < 10) {
    out.message = "fewer than 10 windows of " + std::to_string(o.window_s) + " s with n̂ known";
    return out;
  }
  out.ok = true;
  out.baseline_v = median(means);
  std::vector<double> dev;
  for (double m : means) dev.push_back(std::abs(m - out.baseline_v));
  out.spread_v = 1.4826 * median(dev);
  if (!(out.spread_v > 0.0)) {
    out.message = "the window means do not vary (no spread to judge against)";
    return out;
  }
  const double limit = o.threshold * out.spread_v;
  std::vector<int> sign(win.size(), 0);
  for (std::size_t j = 0; j < win.size(); ++j) {
    if (!std::isfinite(win[j].mean)) continue;
    const double d = win[j].mean - out.baseline_v;
    if (std::abs(d) > limit) sign[j] = d > 0 ? 1 : -1, ++out.active_windows;
  }
  if (static_cast<double>(out.active_windows) >
      o.max_active_share * static_cast<double>(out.windows)) {
    out.message = std::to_string(out.active_windows) + " of " + std::to_string(out.windows) +
                  " windows stand out: the residual is not confined to a few time windows";
    out.active_windows = 0;
    return out;
  }
  // Runs of active windows of one sign → intervals, edges refined to the sample.
  for (std::size_t j = 0; j < win.size();) {
    if (sign[j] == 0) {
      ++j;
      continue;
    }
    std::size_t jb = j;
    while (jb + 1 < win.size() && sign[jb + 1] == sign[j]) ++jb;
    // Across windows not judged, to an active window of the same sign: one interval.
    for (;;) {
      std::size_t k = jb + 1;
      while (k < win.size() && win[k].unjudged) ++k;
      if (k == jb + 1 || k >= win.size() || sign[k] != sign[j]) break;
      jb = k;
      while (jb + 1 < win.size() && sign[jb + 1] == sign[j]) ++jb;
    }
    const std::size_t a = win[j].first, b = win[jb].last;
    double s = 0.0;
    std::size_t m = 0;
    for (std::size_t k = a; k < b; ++k) {
      if (valid[k]) s += n[k] - out.baseline_v, ++m;
    }
    double level = m > 0 ? s / static_cast<double>(m) : 0.0;
    // The edge lies within one window of the active run's ends, or of the windows not judged
    // next to them.
    std::size_t jl = j, jh = jb;
    while (jl > 0 && win[jl - 1].unjudged) --jl;
    while (jh + 1 < win.size() && win[jh + 1].unjudged) ++jh;
    const std::size_t lo = jl > 0 ? win[jl - 1].first : win[jl].first;
    const std::size_t hi = jh + 1 < win.size() ? win[jh + 1].last : win[jh].last;
    const std::size_t mid_a = std::min(win[j].last, b), mid_b = std::max(win[jb].first, a);
    const std::size_t start = refine_edge(n, valid, out.baseline_v, level, lo, hi, mid_a, true);
    const std::size_t end = refine_edge(n, valid, out.baseline_v, level, lo, hi, mid_b, false);
    j = jb + 1;
    if (end <= start) continue;
    s = 0.0, m = 0;
    for (std::size_t k = start; k < end; ++k) {
      if (valid[k]) s += n[k] - out.baseline_v, ++m;
    }
    if (m == 0) continue;
    level = s / static_cast<double>(m);
    DisturbanceInterval iv;
    iv.start_s = t[start];
    iv.end_s = end < t.size() ? t[end] : t.back() + (t.size() > 1 ? t.back() - t[t.size() - 2] : 0.0);
    if (iv.end_s - iv.start_s < o.min_interval_s) continue;
    iv.level_v = level;
    iv.spreads = std::abs(level) / out.spread_v;
    if (!out.intervals.empty() && out.intervals.back().end_s > iv.start_s) {
      iv.start_s = out.intervals.back().end_s;  // refined edges of neighbours may overlap
    }
    for (std::size_t k = start; k < end; ++k) {
      if (t[k] >= iv.start_s) out.d_v[k] = level;
    }
    out.intervals.push_back(iv);
  }
  double ss = 0.0;
  for (double d : out.d_v) ss += d * d;
  out.rms_v = std::sqrt(ss / static_cast<double>(out.d_v.size()));
  if (out.intervals.empty()) out.message = "no window stands out of the spread";
  return out;
}

}  // namespace

}  // namespace alphainv
