#include "alphainv/identify/output_error.hpp"

#include <algorithm>
#include <atomic>
#include <cmath>
#include <memory>
#include <mutex>

#include <Eigen/Dense>
#include <ceres/ceres.h>

#include "alphainv/error.hpp"
#include "alphainv/identify/fit_report.hpp"
#include "alphainv/model/detail/field_checks.hpp"
#include "common/parallel_for.hpp"

namespace alphainv {

namespace {

/// Indices of the residual samples of a run: evenly spaced, at most `max_n`, never sample 0 (the
/// initial state is taken from it).
std::vector<std::size_t> residual_samples(std::size_t n, std::size_t max_n) {
  std::vector<std::size_t> idx;
  if (n < 2) return idx;
  const std::size_t stride = std::max<std::size_t>(1, (n - 1 + max_n - 1) / std::max<std::size_t>(max_n, 1));
  for (std::size_t k = 1; k < n; k += stride) idx.push_back(k);
  return idx;
}

/// Finite-difference step of parameter j at value x: relative to its magnitude and its range.
double fd_step(const OutputErrorParameter& par, double x) {
  double scale = std::abs(x);
  if (std::isfinite(par.lower) && std::isfinite(par.upper)) {
    scale = std::max(scale, 1e-2 * (par.upper - par.lower));
  }
  scale = std::max(scale, std::abs(par.initial));
  return 1e-5 * std::max(scale, 1e-9);
}

/// One run's last simulations at the base points of the fit (never the Jacobian's perturbed
/// ones), and its last Jacobians. The simulation is deterministic in p, so a hit is exactly what
/// simulating again would give. Ceres asks for the same point several times: the bounded
/// problem's projected line search evaluates the cost and gradient at the trust-region step, then
/// the minimiser evaluates the cost there and, when it accepts the step, the residuals and
/// Jacobian again; the residual scale, the standard errors and the final RMS are at points the
/// solver has evaluated. Thread-safe (one mutex; the simulations run outside it).
class RunMemo {
 public:
  /// θ_sim at p (all samples); nullptr when not held. `ok` false: the simulation failed there.
  bool find_theta(const double* p, std::size_t np, std::vector<double>& theta, bool& ok) const {
    const std::lock_guard<std::mutex> lock(mutex_);
    for (const Entry& e : thetas_) {
      if (same(e.p, p, np)) {
        ok = e.ok;
        if (ok) theta = e.values;
        return true;
      }
    }
    return false;
  }
  void add_theta(const double* p, std::size_t np, const std::vector<double>& theta, bool ok) {
    const std::lock_guard<std::mutex> lock(mutex_);
    push(thetas_, {std::vector<double>(p, p + np), ok ? theta : std::vector<double>{}, ok},
         kThetas);
  }
  /// Whether the Jacobian at p with residual scale `scale` is held.
  bool has_jacobian(const double* p, std::size_t np, double scale) const {
    const std::lock_guard<std::mutex> lock(mutex_);
    for (const Entry& e : jacobians_) {
      if (e.scale == scale && same(e.p, p, np)) return true;
    }
    return false;
  }
  /// The Jacobian (row-major, residuals × parameters) at p with residual scale `scale`.
  bool find_jacobian(const double* p, std::size_t np, double scale, double* out) const {
    const std::lock_guard<std::mutex> lock(mutex_);
    for (const Entry& e : jacobians_) {
      if (e.scale == scale && same(e.p, p, np)) {
        std::copy(e.values.begin(), e.values.end(), out);
        return true;
      }
    }
    return false;
  }
  void add_jacobian(const double* p, std::size_t np, double scale, const double* jac,
                    std::size_t size) {
    const std::lock_guard<std::mutex> lock(mutex_);
    Entry e{std::vector<double>(p, p + np), std::vector<double>(jac, jac + size), true};
    e.scale = scale;
    push(jacobians_, std::move(e), kJacobians);
  }

 private:
  struct Entry {
    std::vector<double> p, values;
    bool ok = true;
    double scale = 0.0;
  };
  /// Points held: the line search's trials of one iteration and the accepted point before them.
  static constexpr std::size_t kThetas = 6, kJacobians = 3;
  static bool same(const std::vector<double>& a, const double* p, std::size_t np) {
    return a.size() == np && std::equal(a.begin(), a.end(), p);
  }
  static void push(std::vector<Entry>& v, Entry e, std::size_t cap) {
    if (v.size() >= cap) v.erase(v.begin());
    v.push_back(std::move(e));
  }
  mutable std::mutex mutex_;
  std::vector<Entry> thetas_, jacobians_;
};

/// θ_sim of run i at p through its memo (memo may be null); false when the simulation fails.
bool memo_theta(const OutputErrorProblem& problem, const double* p, std::size_t i, RunMemo* memo,
                std::atomic<long>& sims, std::vector<double>& theta) {
  const std::size_t np = problem.parameters.size();
  bool ok = false;
  if (memo != nullptr && memo->find_theta(p, np, theta, ok)) return ok;
  ++sims;
  SimulationResult sim = simulate_output_error_run(problem, p, i);
  ok = sim.ok && sim.theta.size() == problem.runs[i].data->size();
  if (ok) theta = std::move(sim.theta);
  if (memo != nullptr) memo->add_theta(p, np, theta, ok);
  return ok;
}

/// One run's residuals w·(θ_sim − θ) at its residual samples; Jacobian by central differences.
class RunCost final : public ceres::CostFunction {
 public:
  /// `scale` divides every residual (so that the solver's absolute tolerances see a cost of order
  /// one whatever the position unit). `memo` (may be null) holds the run's recent simulations.
  RunCost(const OutputErrorProblem& problem, std::size_t run, std::atomic<long>& sims,
          double scale, unsigned threads, RunMemo* memo = nullptr)
      : problem_(problem), run_(run), sims_(sims), threads_(threads), memo_(memo), scale_(scale) {
    idx_ = residual_samples(problem.runs[run].data->size(), problem.max_residuals_per_run);
    sqrt_w_ = std::sqrt(problem.runs[run].weight / static_cast<double>(std::max<std::size_t>(idx_.size(), 1))) / scale;
    set_num_residuals(static_cast<int>(idx_.size()));
    mutable_parameter_block_sizes()->push_back(static_cast<int>(problem.parameters.size()));
  }

  bool Evaluate(double const* const* params, double* residuals, double** jacobians) const override {
    const std::size_t np = problem_.parameters.size();
    const double* p = params[0];
    if (!base_residual_at(p, residuals)) return false;
    if (jacobians == nullptr || jacobians[0] == nullptr) return true;
    if (memo_ != nullptr && memo_->find_jacobian(p, np, scale_, jacobians[0])) return true;
    // Central differences, the 2·P perturbed simulations spread over the threads.
    JacobianWork w = jacobian_work();
    common::parallel_for(2 * np, threads_, [&](std::size_t job) { perturbed(p, job, w); });
    finish_jacobian(p, w, jacobians[0]);
    return true;
  }

  /// The 2·P perturbed simulations of a central-difference Jacobian (job 2j: parameter j
  /// stepped up, 2j + 1: down), each job writing only its own slots.
  struct JacobianWork {
    std::vector<std::vector<double>> residuals;  ///< per job, residual_count() values
    std::vector<double> stepped;                 ///< per job, the stepped parameter value
    std::vector<char> ok;                        ///< per job, whether it simulated
  };
  JacobianWork jacobian_work() const {
    const std::size_t jobs = 2 * problem_.parameters.size();
    return {std::vector<std::vector<double>>(jobs, std::vector<double>(idx_.size())),
            std::vector<double>(jobs), std::vector<char>(jobs, 0)};
  }
  /// Job `job` of the Jacobian at p into `w` (thread-safe: writes only the job's slots).
  void perturbed(const double* p, std::size_t job, JacobianWork& w) const {
    const std::size_t np = problem_.parameters.size();
    const std::size_t j = job / 2;
    const OutputErrorParameter& par = problem_.parameters[j];
    const double x = p[j], h = fd_step(par, x);
    w.stepped[job] = job % 2 == 0 ? std::min(x + h, par.upper) : std::max(x - h, par.lower);
    std::vector<double> q(p, p + np);
    q[j] = w.stepped[job];
    w.ok[job] = residual_at(q.data(), w.residuals[job].data());
  }
  /// The Jacobian (row-major) at p from the finished jobs `w` into `jac`, and into the memo.
  void finish_jacobian(const double* p, const JacobianWork& w, double* jac) const {
    const std::size_t np = problem_.parameters.size();
    const std::size_t m = idx_.size();
    for (std::size_t j = 0; j < np; ++j) {
      const double dx = w.stepped[2 * j] - w.stepped[2 * j + 1];
      const bool good = w.ok[2 * j] && w.ok[2 * j + 1] && dx > 0.0;
      const std::vector<double>& plus = w.residuals[2 * j];
      const std::vector<double>& minus = w.residuals[2 * j + 1];
      for (std::size_t i = 0; i < m; ++i) jac[i * np + j] = good ? (plus[i] - minus[i]) / dx : 0.0;
    }
    if (memo_ != nullptr) memo_->add_jacobian(p, np, scale_, jac, m * np);
  }
  /// Whether Evaluate() at p would still compute the Jacobian (no memo, or not held).
  bool needs_jacobian(const double* p) const {
    return memo_ == nullptr || !memo_->has_jacobian(p, problem_.parameters.size(), scale_);
  }
  std::size_t parameter_count() const { return problem_.parameters.size(); }

  /// The residuals at a point the solver asks for (through the memo).
  bool base_residual_at(const double* p, double* out) const {
    std::vector<double> theta;
    if (!memo_theta(problem_, p, run_, memo_, sims_, theta)) return false;
    return residuals_of(theta, out);
  }

  /// The residuals at a perturbed point of the Jacobian (simulated, not memoised).
  bool residual_at(const double* p, double* out) const {
    ++sims_;
    const SimulationResult sim = simulate_output_error_run(problem_, p, run_);
    if (!sim.ok) return false;
    return residuals_of(sim.theta, out);
  }

  bool residuals_of(const std::vector<double>& theta, double* out) const {
    const RunData& d = *problem_.runs[run_].data;
    for (std::size_t i = 0; i < idx_.size(); ++i) {
      const std::size_t k = idx_[i];
      out[i] = sqrt_w_ * (theta[k] - d.theta[k]);
      if (!std::isfinite(out[i])) return false;
    }
    return true;
  }

  std::size_t residual_count() const { return idx_.size(); }

 private:
  const OutputErrorProblem& problem_;
  std::size_t run_;
  std::atomic<long>& sims_;
  unsigned threads_ = 1;
  RunMemo* memo_ = nullptr;
  double scale_ = 1.0;
  std::vector<std::size_t> idx_;
  double sqrt_w_ = 1.0;
};

/// Runs, before Ceres evaluates the runs' costs at a point, the simulations they will ask for:
/// every run's at once over the threads, into the runs' memos, so that RunCost::Evaluate() then
/// reads them. Ceres evaluates the residual blocks one after the other (num_threads = 1, so that
/// its sums over the runs keep one order), and a cost-only evaluation or a Jacobian's base point
/// would otherwise run one run at a time; the values are the same simulations, so the fit is the
/// same bit for bit. Needs every RunCost to have a memo.
class PrefetchSimulations final : public ceres::EvaluationCallback {
 public:
  /// `costs` (owned by the ceres::Problem) evaluated at the parameter block `x`.
  PrefetchSimulations(const double* x, unsigned threads) : x_(x), threads_(threads) {}
  void add(const RunCost* cost) { costs_.push_back(cost); }

  void PrepareForEvaluation(bool evaluate_jacobians, bool new_evaluation_point) override {
    (void)new_evaluation_point;  // the memos know what they hold
    const std::size_t n = costs_.size();
    std::vector<char> base_ok(n, 0);
    common::parallel_for(n, threads_, [&](std::size_t i) {
      std::vector<double> r(costs_[i]->residual_count());
      base_ok[i] = costs_[i]->base_residual_at(x_, r.data());
    });
    if (!evaluate_jacobians) return;
    std::vector<std::size_t> runs;  // the runs whose Jacobian Evaluate() would compute
    for (std::size_t i = 0; i < n; ++i) {
      if (base_ok[i] && costs_[i]->needs_jacobian(x_)) runs.push_back(i);
    }
    if (runs.empty()) return;
    const std::size_t jobs_per_run = 2 * costs_.front()->parameter_count();
    std::vector<RunCost::JacobianWork> work;
    work.reserve(runs.size());
    for (std::size_t i : runs) work.push_back(costs_[i]->jacobian_work());
    common::parallel_for(runs.size() * jobs_per_run, threads_, [&](std::size_t k) {
      const std::size_t r = k / jobs_per_run;
      costs_[runs[r]]->perturbed(x_, k % jobs_per_run, work[r]);
    });
    for (std::size_t r = 0; r < runs.size(); ++r) {
      const RunCost& c = *costs_[runs[r]];
      std::vector<double> jac(c.residual_count() * c.parameter_count());
      c.finish_jacobian(x_, work[r], jac.data());
    }
  }

 private:
  const double* x_;
  unsigned threads_;
  std::vector<const RunCost*> costs_;
};

std::string check_problem(const OutputErrorProblem& pr) {
  if (pr.runs.empty()) return "no runs to fit";
  if (!pr.model) return "no model function";
  for (std::size_t i = 0; i < pr.runs.size(); ++i) {
    if (pr.runs[i].data == nullptr || pr.runs[i].data->size() < 10)
      return "run " + std::to_string(i) + " has fewer than 10 samples";
  }
  for (const auto& par : pr.parameters) {
    if (!(par.lower <= par.initial && par.initial <= par.upper) || !std::isfinite(par.initial))
      return "parameter " + par.name + ": initial value outside its bounds";
  }
  return {};
}

}  // namespace

SimulationResult simulate_output_error_run(const OutputErrorProblem& problem, const double* p,
                                           std::size_t i) {
  const OutputErrorRun& run = problem.runs[i];
  const RunData& d = *run.data;
  const JointModelAtPose model = problem.model(p, i);
  const InitialState x0 = initial_state_of(d, run.start, run.command_history);
  return simulate_recorded_run(model, run.controller, d, x0, problem.simulation);
}

std::vector<double> output_error_rms(const OutputErrorProblem& problem, const std::vector<double>& p,
                                     unsigned threads) {
  std::vector<double> out(problem.runs.size(), std::numeric_limits<double>::quiet_NaN());
  common::parallel_for(problem.runs.size(), threads, [&](std::size_t i) {
    const SimulationResult sim = simulate_output_error_run(problem, p.data(), i);
    if (!sim.ok) return;
    const RunData& d = *problem.runs[i].data;
    double ss = 0.0;
    for (std::size_t k = 0; k < d.size(); ++k) ss += (sim.theta[k] - d.theta[k]) * (sim.theta[k] - d.theta[k]);
    out[i] = std::sqrt(ss / static_cast<double>(d.size()));
  });
  return out;
}

namespace {

/// output_error_rms() through the runs' memos, counting the simulations run.
std::vector<double> memo_rms(const OutputErrorProblem& problem, const std::vector<double>& p,
                             unsigned threads, std::vector<RunMemo>& memos,
                             std::atomic<long>& sims) {
  std::vector<double> out(problem.runs.size(), std::numeric_limits<double>::quiet_NaN());
  common::parallel_for(problem.runs.size(), threads, [&](std::size_t i) {
    std::vector<double> theta;
    if (!memo_theta(problem, p.data(), i, &memos[i], sims, theta)) return;
    const RunData& d = *problem.runs[i].data;
    double ss = 0.0;
    for (std::size_t k = 0; k < d.size(); ++k) ss += (theta[k] - d.theta[k]) * (theta[k] - d.theta[k]);
    out[i] = std::sqrt(ss / static_cast<double>(d.size()));
  });
  return out;
}

/// The starts of the fit: the parameters' initial values, then every extra start of the right
/// size.
std::vector<std::vector<double>> fit_starts(const OutputErrorProblem& problem,
                                            const OutputErrorOptions& options) {
  const std::size_t np = problem.parameters.size();
  std::vector<std::vector<double>> starts;
  {
    std::vector<double> p0(np);
    for (std::size_t j = 0; j < np; ++j) p0[j] = problem.parameters[j].initial;
    starts.push_back(p0);
  }
  for (const auto& s : options.extra_starts) {
    if (s.size() == np) starts.push_back(s);
  }
  return starts;
}

/// The residual scale: the RMS error at the first start (or the RMS of θ if that simulation
/// fails), so that the solver's absolute tolerances see a cost of order one.
double residual_scale(const OutputErrorProblem& problem, const std::vector<double>& start,
                      unsigned threads, std::vector<RunMemo>& memos, std::atomic<long>& sims) {
  double scale = 0.0;
  const std::vector<double> rms0 = memo_rms(problem, start, threads, memos, sims);
  double ss = 0.0;
  for (double x : rms0) ss += std::isfinite(x) ? x * x : 0.0;
  scale = std::sqrt(ss / static_cast<double>(rms0.size()));
  if (!(scale > 0.0) || !std::isfinite(scale)) {
    double th = 0.0;
    std::size_t cnt = 0;
    for (const auto& r : problem.runs) {
      for (double x : r.data->theta) th += x * x;
      cnt += r.data->size();
    }
    scale = std::sqrt(th / static_cast<double>(std::max<std::size_t>(cnt, 1)));
  }
  if (!(scale > 0.0) || !std::isfinite(scale)) scale = 1.0;
  return scale;
}

/// Bounded Levenberg-Marquardt from every start; the lowest final cost wins. Adds the iterations
/// to `res`; returns the winner (empty: no start gave a usable solution) and its Ceres one-line
/// report in `best_report`.
std::vector<double> solve_from_starts(const OutputErrorProblem& problem,
                                      const OutputErrorOptions& options,
                                      const std::vector<std::vector<double>>& starts, double scale,
                                      std::vector<RunMemo>& memos, std::atomic<long>& sims,
                                      OutputErrorResult& res,
                                      std::string& best_report) {
  const std::size_t np = problem.parameters.size();
  double best_cost = std::numeric_limits<double>::infinity();
  std::vector<double> best;
  for (const auto& start : starts) {
    std::vector<double> x = start;
    for (std::size_t j = 0; j < np; ++j)
      x[j] = std::clamp(x[j], problem.parameters[j].lower, problem.parameters[j].upper);
    if (np == 0) {
      best = x;
      break;
    }
    PrefetchSimulations prefetch(x.data(), options.threads);
    ceres::Problem::Options po;
    po.evaluation_callback = &prefetch;
    ceres::Problem cp(po);
    for (std::size_t i = 0; i < problem.runs.size(); ++i) {
      auto* cost = new RunCost(problem, i, sims, scale, options.threads, &memos[i]);
      prefetch.add(cost);
      cp.AddResidualBlock(cost, nullptr, x.data());
    }
    for (std::size_t j = 0; j < np; ++j) {
      const auto& par = problem.parameters[j];
      if (std::isfinite(par.lower)) cp.SetParameterLowerBound(x.data(), static_cast<int>(j), par.lower);
      if (std::isfinite(par.upper)) cp.SetParameterUpperBound(x.data(), static_cast<int>(j), par.upper);
    }
    ceres::Solver::Options so;
    so.linear_solver_type = ceres::DENSE_QR;
    so.max_num_iterations = options.max_iterations;
    so.num_threads = 1;  // the Jacobian's simulations run in parallel inside RunCost
    so.logging_type = ceres::SILENT;
    so.function_tolerance = 1e-8;
    so.parameter_tolerance = 1e-8;
    ceres::Solver::Summary summary;
    ceres::Solve(so, &cp, &summary);
    res.iterations += static_cast<int>(summary.iterations.size());
    if (summary.IsSolutionUsable() && summary.final_cost < best_cost) {
      best_cost = summary.final_cost;
      best = x;
      best_report = summary.BriefReport();
    }
  }
  return best;
}

/// res.standard_errors at `best` from the stacked Jacobian of every run (NaN where not available).
void add_standard_errors(const OutputErrorProblem& problem, const OutputErrorOptions& options,
                         const std::vector<double>& best, double scale,
                         std::vector<RunMemo>& memos, std::atomic<long>& sims,
                         OutputErrorResult& res) {
  const std::size_t np = problem.parameters.size();
  // Standard errors from the stacked Jacobian at the solution: cov = σ² (JᵀJ)⁻¹.
  res.standard_errors.assign(np, std::numeric_limits<double>::quiet_NaN());
  if (np > 0) {
    std::vector<std::unique_ptr<RunCost>> costs;
    std::size_t m = 0;
    for (std::size_t i = 0; i < problem.runs.size(); ++i) {
      costs.push_back(std::make_unique<RunCost>(problem, i, sims, scale, 1, &memos[i]));
      m += costs.back()->residual_count();
    }
    Eigen::MatrixXd jac(m, np);
    std::vector<std::vector<double>> jr(costs.size()), rr(costs.size());
    std::vector<char> ok(costs.size(), 0);
    common::parallel_for(costs.size(), options.threads, [&](std::size_t i) {
      const std::size_t mi = costs[i]->residual_count();
      jr[i].resize(mi * np);
      rr[i].resize(mi);
      const double* params[] = {best.data()};
      double* jacs[] = {jr[i].data()};
      ok[i] = costs[i]->Evaluate(params, rr[i].data(), jacs);
    });
    bool all_ok = std::all_of(ok.begin(), ok.end(), [](char c) { return c != 0; });
    if (all_ok) {
      std::size_t row = 0;
      for (std::size_t i = 0; i < costs.size(); ++i) {
        for (std::size_t a = 0; a < rr[i].size(); ++a, ++row) {
          for (std::size_t j = 0; j < np; ++j)
            jac(static_cast<Eigen::Index>(row), static_cast<Eigen::Index>(j)) = jr[i][a * np + j];
        }
      }
      // Rows are r = s·e with s² = w_i/m_i (the per-run normalisation), e = θ_sim − θ with one
      // variance σ² for all samples: cov = σ² A⁻¹ B A⁻¹, A = J_rᵀJ_r, B = Σ s² J_r,kᵀJ_r,k
      // (the sandwich form; it reduces to σ²(JᵀJ)⁻¹ for equal weights). Serially correlated
      // residuals make these standard errors optimistic: read them as lower bounds.
      Eigen::VectorXd s2(static_cast<Eigen::Index>(m));
      double raw_ss = 0.0;
      {
        std::size_t row2 = 0;
        for (std::size_t i = 0; i < costs.size(); ++i) {
          const double w = problem.runs[i].weight /
                           static_cast<double>(std::max<std::size_t>(rr[i].size(), 1)) /
                           (scale * scale);
          for (double e : rr[i]) {
            s2(static_cast<Eigen::Index>(row2++)) = w;
            raw_ss += e * e / w;
          }
        }
      }
      const double dof = static_cast<double>(m) - static_cast<double>(np);
      const Eigen::MatrixXd a_mat = jac.transpose() * jac;
      const Eigen::MatrixXd b_mat = jac.transpose() * s2.asDiagonal() * jac;
      Eigen::JacobiSVD<Eigen::MatrixXd> svd(a_mat, Eigen::ComputeFullU | Eigen::ComputeFullV);
      const auto& sv = svd.singularValues();
      if (dof > 0 && sv(0) > 0 && sv(sv.size() - 1) > 1e-12 * sv(0)) {
        const auto npi = static_cast<Eigen::Index>(np);
        const Eigen::MatrixXd a_inv = svd.solve(Eigen::MatrixXd::Identity(npi, npi));
        const Eigen::MatrixXd cov = (raw_ss / dof) * a_inv * b_mat * a_inv;
        for (Eigen::Index j = 0; j < npi; ++j)
          res.standard_errors[static_cast<std::size_t>(j)] = std::sqrt(std::max(0.0, cov(j, j)));
        res.correlations.assign(np * np, std::numeric_limits<double>::quiet_NaN());
        for (Eigen::Index i = 0; i < npi; ++i) {
          for (Eigen::Index j = 0; j < npi; ++j) {
            const double d = std::sqrt(cov(i, i) * cov(j, j));
            if (d > 0.0)
              res.correlations[static_cast<std::size_t>(i * npi + j)] = cov(i, j) / d;
          }
        }
      }
    }
  }
}

}  // namespace

OutputErrorResult fit_output_error(const OutputErrorProblem& problem,
                                   const OutputErrorOptions& options) {
  OutputErrorResult res;
  for (const auto& par : problem.parameters) res.parameter_names.push_back(par.name);
  if (std::string why = check_problem(problem); !why.empty()) {
    res.message = why;
    return res;
  }
  try {
    options.validate();
  } catch (const Error& e) {
    res.message = std::string("invalid options: ") + e.what();
    return res;
  }
  const std::vector<std::vector<double>> starts = fit_starts(problem, options);
  std::atomic<long> sims{0};
  std::vector<RunMemo> memos(problem.runs.size());
  const double scale = residual_scale(problem, starts.front(), options.threads, memos, sims);
  std::string best_report;
  const std::vector<double> best =
      solve_from_starts(problem, options, starts, scale, memos, sims, res, best_report);
  if (best.empty()) {
    res.message = "no start gave a usable solution (simulation failed for every start)";
    res.simulations = sims;
    return res;
  }
  res.values = best;
  res.message = best_report;
  add_standard_errors(problem, options, best, scale, memos, sims, res);
  res.run_rms = memo_rms(problem, best, options.threads, memos, sims);
  double ss = 0.0, wsum = 0.0;
  bool all = true;
  for (std::size_t i = 0; i < res.run_rms.size(); ++i) {
    if (!std::isfinite(res.run_rms[i])) all = false;
    ss += problem.runs[i].weight * res.run_rms[i] * res.run_rms[i];
    wsum += problem.runs[i].weight;
  }
  res.rms = all && wsum > 0 ? std::sqrt(ss / wsum) : std::numeric_limits<double>::quiet_NaN();
  res.simulations = sims;
  res.ok = all;
  if (!all) res.message = "the simulation of a run failed at the solution";
  return res;
}

void OutputErrorOptions::validate() const {
  if (max_iterations < 1) {
    detail::bad("OutputErrorOptions::max_iterations", "at least 1 iteration",
                static_cast<double>(max_iterations));
  }
  for (std::size_t s = 0; s < extra_starts.size(); ++s) {
    for (std::size_t j = 0; j < extra_starts[s].size(); ++j) {
      detail::require_finite(
          "OutputErrorOptions::extra_starts[" + std::to_string(s) + "][" + std::to_string(j) + "]",
          extra_starts[s][j]);
    }
  }
}

std::string OutputErrorResult::brief_report() const {
  if (!ok) return "output-error fit: NOT usable: " + message;
  return "output-error fit: usable, " + std::to_string(values.size()) +
         " parameters, RMS of θ − θ_sim " + report_number(rms) + ", " +
         std::to_string(iterations) + " iterations, " + std::to_string(simulations) +
         " simulations";
}

std::string OutputErrorResult::full_report() const {
  std::string out = brief_report() + "\n";
  for (std::size_t j = 0; j < values.size(); ++j) {
    const double se =
        j < standard_errors.size() ? standard_errors[j] : std::numeric_limits<double>::quiet_NaN();
    out += "  " + (j < parameter_names.size() ? parameter_names[j] : "p" + std::to_string(j)) +
           " = " + report_number(values[j], "%.6g") + " ± " + report_number(se, "%.3g") + "\n";
  }
  for (std::size_t i = 0; i < run_rms.size(); ++i) {
    out += "  run " + std::to_string(i) + ": RMS of θ − θ_sim " + report_number(run_rms[i]) + "\n";
  }
  if (ok) out += "  " + message + "\n";
  return out;
}

}  // namespace alphainv