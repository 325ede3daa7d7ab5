#include "alphainv/identify/alpha_fit.hpp"

#include <nlopt.h>

#include <Eigen/Dense>
#include <algorithm>
#include <cmath>
#include <functional>
#include <limits>

namespace alphainv {

namespace {

constexpr double kNaN = std::numeric_limits<double>::quiet_NaN();

/// Hat-basis row of the piecewise-linear interpolant held outside the breakpoints (eq. (38)).
template <typename Row>
void hat_row(const std::vector<double>& bp, double alpha, Row&& row) {
  row.setZero();
  const std::size_t n = bp.size();
  if (alpha <= bp[0]) {
    row(0) = 1.0;
    return;
  }
  if (alpha >= bp[n - 1]) {
    row(static_cast<Eigen::Index>(n - 1)) = 1.0;
    return;
  }
  std::size_t k = 1;
  while (alpha > bp[k]) ++k;
  const double w = (alpha - bp[k - 1]) / (bp[k] - bp[k - 1]);
  row(static_cast<Eigen::Index>(k - 1)) = 1.0 - w;
  row(static_cast<Eigen::Index>(k)) = w;
}

/// Least squares through the origin y = b·x: slope and its standard error.
void origin_regression(const std::vector<double>& x, const std::vector<double>& y, double& slope,
                       double& se) {
  double sxx = 0.0, sxy = 0.0;
  for (std::size_t k = 0; k < x.size(); ++k) {
    sxx += x[k] * x[k];
    sxy += x[k] * y[k];
  }
  slope = sxy / sxx;
  if (x.size() < 2) {
    se = kNaN;
    return;
  }
  double ss = 0.0;
  for (std::size_t k = 0; k < x.size(); ++k) ss += std::pow(y[k] - slope * x[k], 2);
  se = std::sqrt(ss / static_cast<double>(x.size() - 1) / sxx);
}

/// What the data pin down (AlphaFitResult::breakpoint_identifiable etc.): data support around each
/// breakpoint, and the stage-2 relative standard errors (scatter of (40), (42) across poses).
void assess_identifiability(const std::vector<AlphaFitPose>& poses, const AlphaFitOptions& options,
                            AlphaFitResult& out) {
  const AlphaModel& m = out.model;
  const std::size_t n = m.n_breakpoints;
  std::vector<double> alphas;
  for (const AlphaFitPose& pose : poses) {
    for (const auto& p : pose.points) {
      if (p.physical && std::isfinite(p.alpha_data) && pose.inertia > 0.0)
        alphas.push_back(p.alpha_data);
    }
  }
  if (alphas.empty() || n < 2) return;
  out.alpha_data_min = *std::min_element(alphas.begin(), alphas.end());
  out.alpha_data_max = *std::max_element(alphas.begin(), alphas.end());
  auto count_in = [&](double lo, double hi) {  // points with lo < α < hi
    return std::count_if(alphas.begin(), alphas.end(), [&](double a) { return a > lo && a < hi; });
  };
  auto se_ok = [&](double value, double se) {
    return !std::isfinite(se) || std::abs(se) <= options.identifiable_relative_se * std::abs(value);
  };
  const double inf = std::numeric_limits<double>::infinity();
  for (std::size_t k = 0; k < n; ++k) {
    const double below = k > 0 ? m.alpha[k - 1] : -inf;
    const double above = k + 1 < n ? m.alpha[k + 1] : inf;
    // The top breakpoint starts the held segment: only data well above it (two or more points, up
    // to 1.5·α_k) show the hold; with fewer, any α_k near or above the data's top fits as well
    // (with C_k moved along the last line), so neither α_k nor C_k is pinned.
    const bool top = k + 1 == n;
    out.breakpoint_identifiable[k] =
        k > 0 && count_in(below, m.alpha[k]) > 0 &&
        (top ? count_in(m.alpha[k], above) >= 2 && out.alpha_data_max >= 1.5 * m.alpha[k]
             : count_in(m.alpha[k], above) > 0);
    // C_k at α_k is measured, not extrapolated, when α_k lies within the data (α0 = 0: when the
    // first segment holds points, C_0 is its line's mild extrapolation to α = 0).
    const bool supported = k == 0 ? count_in(-inf, m.alpha[1]) >= 2
                           : top  ? out.breakpoint_identifiable[k]
                                  : m.alpha[k] <= out.alpha_data_max && count_in(below, above) > 0;
    out.c_n1_identifiable[k] = supported && se_ok(m.c_n1[k], out.c_n1_se[k]);
  }
  out.beta_n1_identifiable[0] = se_ok(m.beta_n1[0], out.beta_n1_se[0]);
  out.beta_n1_identifiable[1] =
      m.beta_alpha[1] <= out.alpha_data_max && se_ok(m.beta_n1[1], out.beta_n1_se[1]);
}

/// The local breakpoint search: x = (ln α1, ln(α2/α1), …, ln(α_{N−1}/α_{N−2})), so that any x in
/// the bounds is a strictly increasing set.
struct RefineContext {
  const std::vector<AlphaFitPose>* poses = nullptr;
  const AlphaFitOptions* options = nullptr;
  std::size_t n = 0;
  int evaluations = 0;
  double best_score = std::numeric_limits<double>::infinity();
  AlphaFitResult best;
};

std::vector<double> breakpoints_from_x(const double* x, std::size_t n) {
  std::vector<double> bp(n, 0.0);
  double log_alpha = 0.0;
  for (std::size_t j = 1; j < n; ++j) {
    log_alpha = j == 1 ? x[0] : log_alpha + x[j - 1];
    bp[j] = std::exp(log_alpha);
  }
  return bp;
}

double refine_objective(unsigned nx, const double* x, double* /*grad*/, void* data) {
  auto* ctx = static_cast<RefineContext*>(data);
  ++ctx->evaluations;
  const std::vector<double> bp = breakpoints_from_x(x, ctx->n);
  (void)nx;
  AlphaFitResult r = fit_alpha_model_at(*ctx->poses, bp, *ctx->options);
  if (!r.ok || !std::isfinite(r.score)) return 1e10;  // invalid set: a wall for Nelder-Mead
  const double score = r.score;
  if (score < ctx->best_score) {
    ctx->best_score = score;
    ctx->best = std::move(r);
  }
  return score;
}

}  // namespace

AlphaFitResult fit_alpha_model_at(const std::vector<AlphaFitPose>& poses,
                                  const std::vector<double>& bp, const AlphaFitOptions& options) {
  AlphaFitResult out;
  const std::size_t n = bp.size();
  if (n < 2 || n > kMaxBreakpoints) {
    out.message = "the number of breakpoints must be in [2, " + std::to_string(kMaxBreakpoints) + "]";
    return out;
  }
  for (std::size_t k = 1; k < n; ++k) {
    if (!(bp[k] > bp[k - 1])) {
      out.message = "breakpoints must strictly increase";
      return out;
    }
  }
  std::vector<double> inertia;  // one per usable pose
  std::vector<std::vector<double>> c_by_bp(n), b_by_end(2);
  for (const AlphaFitPose& pose : poses) {
    std::vector<const LocalLinearPoint*> pts;
    for (const auto& p : pose.points) {
      if (p.physical && std::isfinite(p.alpha_data) && p.beta_data > 0.0) pts.push_back(&p);
    }
    if (pts.size() < 2 || !(pose.inertia > 0.0)) continue;
    const auto m = static_cast<Eigen::Index>(pts.size());
    const auto nn = static_cast<Eigen::Index>(n);
    // Stage 1, damping: relative least squares of C_data on the hat basis, with a small ridge
    // towards the pose's mean C so that segments without points stay determined.
    double c_mean = 0.0;
    for (const auto* p : pts) c_mean += p->c_data / static_cast<double>(pts.size());
    Eigen::MatrixXd a = Eigen::MatrixXd::Zero(m + nn, nn);
    Eigen::VectorXd y = Eigen::VectorXd::Zero(m + nn);
    for (Eigen::Index i = 0; i < m; ++i) {
      hat_row(bp, pts[static_cast<std::size_t>(i)]->alpha_data, a.row(i));
      const double w = 1.0 / pts[static_cast<std::size_t>(i)]->c_data;
      a.row(i) *= w;
      y(i) = 1.0;
    }
    const double lam = std::sqrt(options.ridge);
    for (Eigen::Index j = 0; j < nn; ++j) {
      a(m + j, j) = lam / c_mean;
      y(m + j) = lam;
    }
    const Eigen::VectorXd c = a.colPivHouseholderQr().solve(y);
    // Stage 1, torque constant: β̃_data = β_data/kp linear in α between ᾱ0 = α0 and ᾱ1 = α_{N−1}.
    Eigen::MatrixXd ab(m, 2);
    Eigen::VectorXd yb(m);
    for (Eigen::Index i = 0; i < m; ++i) {
      const auto* p = pts[static_cast<std::size_t>(i)];
      const double s = std::clamp((p->alpha_data - bp[0]) / (bp[n - 1] - bp[0]), 0.0, 1.0);
      const double bt = p->beta_data / options.kp;
      ab(i, 0) = (1.0 - s) / bt;
      ab(i, 1) = s / bt;
      yb(i) = 1.0;
    }
    const Eigen::Vector2d b = ab.colPivHouseholderQr().solve(yb);
    if (!c.allFinite() || !b.allFinite() || (c.array() <= 0.0).any() || (b.array() <= 0.0).any()) {
      continue;  // this pose cannot support the model; stage 2 goes on without it
    }
    inertia.push_back(pose.inertia);
    std::vector<double> cv(n);
    for (std::size_t j = 0; j < n; ++j) {
      cv[j] = c(static_cast<Eigen::Index>(j));
      c_by_bp[j].push_back(1.0 / cv[j]);  // eq. (40) inverted: 1/C_n = C_n1·I
    }
    out.pose_c.push_back(cv);
    out.pose_beta_tilde.push_back({b(0), b(1)});
    b_by_end[0].push_back(1.0 / b(0));  // eq. (42) inverted: 1/β̃_n = β̃_n1·I
    b_by_end[1].push_back(1.0 / b(1));
  }
  if (inertia.empty()) {
    out.message = "no pose has two or more physical sine points with a positive fit";
    return out;
  }
  // Stage 2: ordinary least squares through the origin across poses.
  AlphaModel& model = out.model;
  model.n_breakpoints = n;
  for (std::size_t j = 0; j < n; ++j) {
    model.alpha[j] = bp[j];
    origin_regression(inertia, c_by_bp[j], model.c_n1[j], out.c_n1_se[j]);
  }
  model.beta_alpha = {bp[0], bp[n - 1]};
  origin_regression(inertia, b_by_end[0], model.beta_n1[0], out.beta_n1_se[0]);
  origin_regression(inertia, b_by_end[1], model.beta_n1[1], out.beta_n1_se[1]);
  // Quality on the data.
  double sc = 0.0, sb = 0.0;
  std::size_t count = 0;
  for (const AlphaFitPose& pose : poses) {
    for (const auto& p : pose.points) {
      if (!p.physical || !(pose.inertia > 0.0)) continue;
      sc += std::pow(model.damping(p.alpha_data, pose.inertia) / p.c_data - 1.0, 2);
      sb += std::pow(model.beta_tilde(p.alpha_data, pose.inertia) * options.kp / p.beta_data - 1.0, 2);
      ++count;
    }
  }
  out.points_used = count;
  out.c_rms_relative = std::sqrt(sc / static_cast<double>(count));
  out.beta_rms_relative = std::sqrt(sb / static_cast<double>(count));
  out.score =
      out.c_rms_relative * out.c_rms_relative + out.beta_rms_relative * out.beta_rms_relative;
  out.ok = model.valid();
  out.message = out.ok ? "ok" : "the fitted model is not valid (non-positive coefficients)";
  assess_identifiability(poses, options, out);
  return out;
}

std::vector<double> alpha_model_pose_inertia(const std::vector<AlphaFitPose>& poses,
                                             const AlphaModel& model, double kp) {
  std::vector<double> out;
  for (const AlphaFitPose& pose : poses) {
    double sxx = 0.0, sx = 0.0;
    for (const auto& p : pose.points) {
      if (!p.physical || !std::isfinite(p.alpha_data) || !(p.beta_data > 0.0)) continue;
      const double xc = model.damping(p.alpha_data, 1.0) / p.c_data;             // c(α)/C_data
      const double xb = model.beta_tilde(p.alpha_data, 1.0) * kp / p.beta_data;  // b(α)/β̃_data
      sxx += xc * xc + xb * xb;
      sx += xc + xb;
    }
    out.push_back(sxx > 0.0 && sx > 0.0 ? sxx / sx : kNaN);  // I = 1/u, u = Σx/Σx²
  }
  return out;
}

AlphaFitResult fit_alpha_model(const std::vector<AlphaFitPose>& poses,
                               const AlphaFitOptions& options) {
  AlphaFitResult best;
  best.message = "no candidate breakpoints";
  const std::size_t n = options.n_breakpoints;
  if (n < 2 || n > kMaxBreakpoints) {
    best.message = "n_breakpoints must be in [2, " + std::to_string(kMaxBreakpoints) + "]";
    return best;
  }
  double lo = std::numeric_limits<double>::infinity(), hi = 0.0;
  for (const auto& pose : poses) {
    for (const auto& p : pose.points) {
      if (p.physical && p.alpha_data > 0.0 && std::isfinite(p.alpha_data)) {
        lo = std::min(lo, p.alpha_data);
        hi = std::max(hi, p.alpha_data);
      }
    }
  }
  if (!(hi > lo)) {
    best.message = "need physical sine points at two or more distinct alpha values";
    return best;
  }
  // Log-spaced grid from the smallest to twice the largest α of the data.
  const std::size_t g = std::max<std::size_t>(options.grid_size, n);
  std::vector<double> grid(g);
  for (std::size_t k = 0; k < g; ++k) {
    grid[k] = lo * std::pow(2.0 * hi / lo, static_cast<double>(k) / static_cast<double>(g - 1));
  }
  // Exhaustive search over increasing (N−1)-subsets of the grid; α0 = 0.
  std::vector<std::size_t> idx(n - 1);
  double best_score = std::numeric_limits<double>::infinity();
  std::size_t tried = 0;
  std::vector<std::pair<double, std::vector<double>>> ranked;  // (score, breakpoints)
  std::function<void(std::size_t, std::size_t)> rec = [&](std::size_t depth, std::size_t start) {
    if (depth == n - 1) {
      std::vector<double> bp(n, 0.0);
      for (std::size_t j = 0; j + 1 < n; ++j) bp[j + 1] = grid[idx[j]];
      ++tried;
      AlphaFitResult r = fit_alpha_model_at(poses, bp, options);
      if (!r.ok) return;
      const double score = r.score;
      if (options.keep_runners_up > 0) ranked.push_back({score, bp});
      if (score < best_score) {
        best_score = score;
        best = std::move(r);
      }
      return;
    }
    for (std::size_t k = start; k < g; ++k) {
      idx[depth] = k;
      rec(depth + 1, k + 1);
    }
  };
  rec(0, 0);
  best.candidates_tried = tried;
  if (options.keep_runners_up > 0 && ranked.size() > 1) {
    const std::size_t keep = std::min(ranked.size() - 1, options.keep_runners_up);
    std::partial_sort(ranked.begin(), ranked.begin() + static_cast<std::ptrdiff_t>(keep + 1),
                      ranked.end(),
                      [](const auto& a, const auto& b) { return a.first < b.first; });
    for (std::size_t k = 1; k <= keep; ++k) best.runners_up.push_back(ranked[k].second);
  }
  if (!best.ok && best.message == "no candidate breakpoints") best.message = "no breakpoint set gave a valid model";
  if (!best.ok) return best;
  best.grid_score = best.score;
  if (!options.refine || n < 2) return best;
  // Local refinement off the grid. The score is continuous in the breakpoints but has kinks where
  // a breakpoint crosses a data point's α (the hat basis (38) switches segment), so a method that
  // builds quadratic models from smoothness (BOBYQA) or needs gradients is the wrong tool;
  // Nelder-Mead (NLopt LN_NELDERMEAD, bound-constrained) only compares values and copes with kinks.
  // Start: the grid winner, first simplex step 0.25 in ln α (about a third of the grid spacing);
  // bounds keep α1 ≥ lo/10, α_{N−1} ≤ 10·hi (guarded in the objective too) and each ratio
  // α_{j+1}/α_j in [1.05, 1e4].
  RefineContext ctx;
  ctx.poses = &poses;
  ctx.options = &options;
  ctx.n = n;
  ctx.best_score = best.score;
  ctx.best = best;
  const unsigned nx = static_cast<unsigned>(n - 1);
  std::vector<double> x(nx), lb(nx), ub(nx), step(nx, 0.25);
  for (std::size_t j = 1; j < n; ++j) {
    x[j - 1] = j == 1 ? std::log(best.model.alpha[1])
                      : std::log(best.model.alpha[j] / best.model.alpha[j - 1]);
    lb[j - 1] = j == 1 ? std::log(lo / 10.0) : std::log(1.05);
    ub[j - 1] = j == 1 ? std::log(10.0 * hi) : std::log(1e4);
    x[j - 1] = std::clamp(x[j - 1], lb[j - 1], ub[j - 1]);
  }
  nlopt_opt opt = nlopt_create(NLOPT_LN_NELDERMEAD, nx);
  if (opt != nullptr) {
    nlopt_set_lower_bounds(opt, lb.data());
    nlopt_set_upper_bounds(opt, ub.data());
    nlopt_set_initial_step(opt, step.data());
    nlopt_set_min_objective(opt, refine_objective, &ctx);
    nlopt_set_xtol_abs1(opt, 1e-4);  // 0.01 % in α
    nlopt_set_ftol_rel(opt, 1e-9);
    nlopt_set_maxeval(opt, std::max(1, options.refine_max_evaluations));
    double f = 0.0;
    (void)nlopt_optimize(opt, x.data(), &f);  // the best point seen is kept in ctx whatever it says
    nlopt_destroy(opt);
  }
  const double grid_score = best.grid_score;
  const std::size_t candidates = best.candidates_tried;
  if (ctx.best_score < grid_score) {
    best = std::move(ctx.best);
    best.refined = true;
  }
  best.grid_score = grid_score;
  best.candidates_tried = candidates;
  best.refine_evaluations = ctx.evaluations;
  return best;
}

}  // namespace alphainv
