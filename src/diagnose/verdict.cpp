#include "alphainv/diagnose/verdict.hpp"

#include <algorithm>
#include <cmath>

#include <Eigen/Dense>

#include "common/format.hpp"

namespace alphainv {

namespace {

constexpr double kNaN = std::numeric_limits<double>::quiet_NaN();
constexpr double kTwoPi = 6.283185307179586476925;

std::string num(double x, const char* f = "%.3g") { return common::format(f, x); }

double median(std::vector<double> x) {
  if (x.empty()) return kNaN;
  const std::size_t h = x.size() / 2;
  std::nth_element(x.begin(), x.begin() + static_cast<std::ptrdiff_t>(h), x.end());
  return x[h];
}

double rms(const std::vector<double>& x) {
  if (x.empty()) return kNaN;
  double s = 0.0;
  for (double v : x) s += v * v;
  return std::sqrt(s / static_cast<double>(x.size()));
}

/// sqrt(mean(Δ²e²)/6): the white part of e (Var Δ²e = 6σ² for white noise).
double white_part(const std::vector<double>& e) {
  if (e.size() < 10) return kNaN;
  double s = 0.0;
  for (std::size_t k = 1; k + 1 < e.size(); ++k) {
    const double d2 = e[k + 1] - 2.0 * e[k] + e[k - 1];
    s += d2 * d2;
  }
  return std::sqrt(s / static_cast<double>(e.size() - 2) / 6.0);
}

/// Times of the reference jumps: steps larger than 20× the median |Δr| and 1 % of the r range
/// (as ResidualLocation's jumps).
std::vector<double> jump_times(const ResidualSeries& s) {
  std::vector<double> out;
  if (s.r.size() != s.t.size() || s.r.size() < 3) return out;
  std::vector<double> dr;
  for (std::size_t k = 1; k < s.r.size(); ++k) dr.push_back(std::abs(s.r[k] - s.r[k - 1]));
  const auto [lo, hi] = std::minmax_element(s.r.begin(), s.r.end());
  const double dr_med = median(dr);
  for (std::size_t k = 1; k < s.r.size(); ++k) {
    if (dr[k - 1] > 20.0 * dr_med && dr[k - 1] > 0.01 * (*hi - *lo)) out.push_back(s.t[k]);
  }
  return out;
}

bool is_sine(const ResidualSeries& s) {
  return s.kind == "sine" && s.freq_hz && *s.freq_hz > 0.0;
}

/// The least-squares fit of e[first…] by a constant and harmonics 1…n of f; `fit` receives the
/// fitted values per part (0: constant, k: harmonic k).
bool fit_harmonics(const ResidualSeries& s, std::size_t first, double f, int n,
                   std::vector<std::vector<double>>& parts) {
  const std::size_t m = s.t.size() - first;
  const Eigen::Index p = 1 + 2 * n;
  if (m < static_cast<std::size_t>(2 * p)) return false;
  Eigen::MatrixXd x(static_cast<Eigen::Index>(m), p);
  Eigen::VectorXd y(static_cast<Eigen::Index>(m));
  for (std::size_t i = 0; i < m; ++i) {
    const auto row = static_cast<Eigen::Index>(i);
    const double w = kTwoPi * f * s.t[first + i];
    x(row, 0) = 1.0;
    for (int k = 1; k <= n; ++k) {
      x(row, 2 * k - 1) = std::sin(k * w);
      x(row, 2 * k) = std::cos(k * w);
    }
    y(row) = s.residual[first + i];
  }
  const Eigen::VectorXd b = x.colPivHouseholderQr().solve(y);
  parts.assign(static_cast<std::size_t>(n) + 1, std::vector<double>(m, 0.0));
  for (std::size_t i = 0; i < m; ++i) {
    const auto row = static_cast<Eigen::Index>(i);
    parts[0][i] = b(0);
    for (int k = 1; k <= n; ++k) {
      parts[static_cast<std::size_t>(k)][i] =
          b(2 * k - 1) * x(row, 2 * k - 1) + b(2 * k) * x(row, 2 * k);
    }
  }
  return true;
}

/// Samples of `s` outside its transients: not within transient_s of the start or after a jump
/// (sine runs: their steady state from `first` only).
std::vector<bool> judged_mask(const ResidualSeries& s, const VerdictOptions& o, std::size_t first) {
  std::vector<bool> m(s.t.size(), false);
  const std::vector<double> jumps = jump_times(s);
  std::size_t j = 0;
  for (std::size_t k = first; k < s.t.size(); ++k) {
    if (s.t[k] - s.t.front() < o.transient_s) continue;
    while (j < jumps.size() && jumps[j] + o.transient_s < s.t[k]) ++j;
    if (j < jumps.size() && s.t[k] >= jumps[j]) continue;
    m[k] = true;
  }
  return m;
}

/// harmonic_parts() that also gives the fitted parts (fit_harmonics'): one fit for both.
HarmonicParts harmonic_parts_and_fit(const ResidualSeries& s, double f, int n,
                                     std::vector<std::vector<double>>& parts);
void add_structure(const ResidualSeries& s, const std::vector<bool>& mask, std::size_t first,
                   const std::vector<double>& fundamental, double& ss, double& n);

}  // namespace

const char* verdict_name(ResidualVerdict v) {
  return v == ResidualVerdict::kExplained ? "explained" : "structure_remains";
}

HarmonicParts harmonic_parts(const ResidualSeries& s, double f, int n) {
  std::vector<std::vector<double>> parts;
  return harmonic_parts_and_fit(s, f, n, parts);
}

namespace {

HarmonicParts harmonic_parts_and_fit(const ResidualSeries& s, double f, int n,
                                     std::vector<std::vector<double>>& parts) {
  HarmonicParts h;
  if (s.t.size() != s.residual.size() || s.t.size() < 20 || !(f > 0.0)) return h;
  const double duration = s.t.back() - s.t.front();
  const double cycles = std::floor(0.5 * duration * f);
  if (cycles < 2.0) return h;
  const double t0 = s.t.back() - cycles / f;
  while (h.first < s.t.size() && s.t[h.first] < t0) ++h.first;
  if (!fit_harmonics(s, h.first, f, n, parts)) return h;
  const std::size_t m = s.t.size() - h.first;
  std::vector<double> rest(m), rep(m), harm(m, 0.0);
  double best = 0.0;
  for (int k = 2; k <= n; ++k) {
    const double e = rms(parts[static_cast<std::size_t>(k)]);
    if (e > best) best = e, h.strongest = k;
  }
  for (std::size_t i = 0; i < m; ++i) {
    double all = 0.0;
    for (std::size_t k = 0; k < parts.size(); ++k) all += parts[k][i];
    for (std::size_t k = 2; k < parts.size(); ++k) harm[i] += parts[k][i];
    rep[i] = all;
    rest[i] = s.residual[h.first + i] - all;
  }
  h.mean = parts[0].front();
  h.fundamental = rms(parts[1]);
  h.harmonics = rms(harm);
  h.rest = rms(rest);
  h.repeating = rms(rep);
  h.ok = true;
  return h;
}

/// Adds the judged samples (`mask`) of `s` to (ss, n), without its part at the fundamental
/// `fundamental` (fitted from sample `first`; empty: none): structure_rms()'s sum.
void add_structure(const ResidualSeries& s, const std::vector<bool>& mask, std::size_t first,
                   const std::vector<double>& fundamental, double& ss, double& n) {
  for (std::size_t k = 0; k < s.residual.size(); ++k) {
    if (!mask[k]) continue;
    const double e = s.residual[k] - (k >= first && k - first < fundamental.size() ? fundamental[k - first] : 0.0);
    ss += e * e, n += 1.0;
  }
}

}  // namespace

NoiseFloor estimate_noise_floor(const std::vector<ResidualSeries>& runs, const VerdictOptions& o) {
  NoiseFloor f;
  std::vector<double> white, cyc;
  for (const ResidualSeries& s : runs) {
    const double w = white_part(s.residual);
    if (std::isfinite(w)) white.push_back(w);
    if (is_sine(s)) {
      const HarmonicParts h = harmonic_parts(s, *s.freq_hz, o.harmonics);
      if (h.ok) cyc.push_back(h.rest);
    }
  }
  f.white = median(white);
  f.cycle_to_cycle = median(cyc);
  f.rms = f.white;
  return f;
}

double structure_rms(const std::vector<ResidualSeries>& runs, const VerdictOptions& o) {
  double ss = 0.0, n = 0.0;
  for (const ResidualSeries& s : runs) {
    if (s.t.size() != s.residual.size() || s.t.size() < 20) continue;
    std::vector<std::vector<double>> parts;
    const HarmonicParts h = is_sine(s) ? harmonic_parts_and_fit(s, *s.freq_hz, o.harmonics, parts)
                                       : HarmonicParts{};
    const std::size_t first = h.ok ? h.first : 0;
    add_structure(s, judged_mask(s, o, first), first, h.ok ? parts[1] : std::vector<double>{}, ss, n);
  }
  return n > 0.0 ? std::sqrt(ss / n) : kNaN;
}

VerdictReport judge_residual(const std::vector<ResidualSeries>& runs, const NoiseFloor& floor,
                             const VerdictOptions& o) {
  VerdictReport rep;
  rep.floor = floor;
  rep.ratio = o.ratio;
  const double fl = floor.rms;
  if (!(std::isfinite(fl) && fl > 0.0)) {
    rep.structure_rms = structure_rms(runs, o);
    rep.verdict = ResidualVerdict::kStructureRemains;
    rep.unexplained.push_back({"no noise floor could be estimated from the data", 0.0, 0.0});
    return rep;
  }
  auto add = [&](const std::string& where, double size) {
    if (std::isfinite(size) && size > o.ratio * fl) rep.unexplained.push_back({where, size, size / fl});
  };
  double ss_j = 0.0, n_j = 0.0, ss_t = 0.0, n_t = 0.0, ss_s = 0.0, n_s = 0.0;
  struct Fundamental { double rms; const ResidualSeries* run; };
  std::vector<Fundamental> fundamentals;  // the sine runs' errors at the fundamental
  std::vector<UnexplainedPart> rests;     // sine runs whose part that does not repeat is large
  std::vector<double> rest_sizes;         // … and that part of every sine run
  for (const ResidualSeries& s : runs) {
    if (s.t.size() != s.residual.size() || s.t.size() < 20) continue;
    std::size_t first = 0;
    std::vector<double> windowed = s.residual;  // what the time windows look at
    const bool sine = is_sine(s);
    HarmonicParts h;
    std::vector<std::vector<double>> parts;
    if (sine) {
      h = harmonic_parts_and_fit(s, *s.freq_hz, o.harmonics, parts);
      if (h.ok) {
        fundamentals.push_back({h.fundamental, &s});
        first = h.first;
        for (std::size_t i = first; i < s.t.size(); ++i) {
          for (const auto& p : parts) windowed[i] -= p[i - first];
        }
        const std::string run = "run " + s.name + " (" + num(*s.freq_hz, "%g") + " Hz, steady state)";
        // What the α-model cannot make: harmonics of the fundamental and a constant (its
        // error at the fundamental is a gain and phase, which C(α) and β̃(α) represent: said,
        // not judged).
        const double shape = std::hypot(h.harmonics, h.mean);
        if (shape > o.ratio * fl) {
          std::string what = run + ": error repeating every cycle: harmonics 2–" +
                             std::to_string(o.harmonics) + " " + num(h.harmonics) +
                             (h.strongest > 0 ? " (strongest " + std::to_string(h.strongest) + ")" : "") +
                             ", constant " + num(h.mean) + " (and at the fundamental " +
                             num(h.fundamental) + ")";
          add(what, shape);
        }
        rest_sizes.push_back(h.rest);
        if (h.rest > o.ratio * fl) {
          rests.push_back({run + ": error not repeating from cycle to cycle (a slow transient near a "
                           "resonance, or a motion not locked to the reference)",
                           h.rest, h.rest / fl});
        }
      }
    }
    const std::vector<bool> mask = judged_mask(s, o, first);
    add_structure(s, mask, first, h.ok ? parts[1] : std::vector<double>{}, ss_s, n_s);
    std::vector<double> judged;
    for (std::size_t k = 0; k < s.t.size(); ++k) {
      const double e2 = s.residual[k] * s.residual[k];
      if (mask[k]) {
        judged.push_back(s.residual[k]);
        ss_j += e2, n_j += 1;
      } else {
        ss_t += e2, n_t += 1;
      }
    }
    if (!sine || !h.ok) add("run " + s.name + " outside transients", rms(judged));
    // Time windows of the part that does not repeat.
    struct Window { double t0, t1, rms; };
    std::vector<Window> wins;
    std::size_t k = 0;
    while (k < s.t.size()) {
      if (!mask[k]) { ++k; continue; }
      const double t0 = s.t[k];
      double ss = 0.0, n = 0.0;
      std::size_t j = k;
      for (; j < s.t.size() && mask[j] && s.t[j] < t0 + o.window_s; ++j) ss += windowed[j] * windowed[j], n += 1;
      if (n >= 10) wins.push_back({t0, s.t[j - 1], std::sqrt(ss / n)});
      k = j;
    }
    std::vector<double> wr;
    for (const Window& w : wins) wr.push_back(w.rms);
    const double med = median(wr);
    // Flagged windows, adjacent ones merged.
    for (std::size_t a = 0; a < wins.size();) {
      auto flagged = [&](const Window& w) {
        return w.rms > o.window_ratio * med && w.rms > o.window_floor_ratio * fl;
      };
      if (!flagged(wins[a])) { ++a; continue; }
      std::size_t b = a;
      double ss = 0.0, peak = 0.0;
      while (b < wins.size() && flagged(wins[b])) {
        ss += wins[b].rms * wins[b].rms;
        peak = std::max(peak, wins[b].rms);
        ++b;
      }
      const double size = std::sqrt(ss / static_cast<double>(b - a));
      add("run " + s.name + ", t = " + num(wins[a].t0, "%.2f") + "–" + num(wins[b - 1].t1, "%.2f") +
              " s: a time window " + num(size / med, "%.0f") + "× the run's median window" +
              (sine ? " (after the repeating part)" : ""),
          size);
      a = b;
    }
  }
  rep.cycle_to_cycle = median(rest_sizes);  // of the residual judged, not the floor's
  if (std::isfinite(rep.cycle_to_cycle) && rep.cycle_to_cycle > o.ratio * fl) {
    add("the sine runs' steady state, not repeating from cycle to cycle (drift, disturbances)",
        rep.cycle_to_cycle);
  } else {
    rep.not_judged = std::move(rests);  // judged by their median only (file comment)
  }
  // The sine runs' errors at the fundamental together (file comment): one or two runs near a
  // resonance may miss it, most may not.
  rep.fundamental_runs = fundamentals.size();
  if (fundamentals.size() >= std::max<std::size_t>(o.min_sine_runs, 1)) {
    std::vector<double> sizes;
    const Fundamental* largest = &fundamentals.front();
    for (const Fundamental& f : fundamentals) {
      sizes.push_back(f.rms);
      if (f.rms > o.ratio * fl) ++rep.fundamental_runs_above;
      if (f.rms > largest->rms) largest = &f;
    }
    rep.fundamental_median = median(sizes);
    add("the sine runs' steady state at the fundamental: " + std::to_string(rep.fundamental_runs_above) +
            " of " + std::to_string(fundamentals.size()) + " runs miss their gain and phase (median " +
            num(rep.fundamental_median) + ", largest " + num(largest->rms) + " in run " + largest->run->name +
            "): no one α-model gives every run its own (a level that changes between runs, or an "
            "effect the α-model takes in only in part)",
        rep.fundamental_median);
  }
  rep.judged_rms = n_j > 0 ? std::sqrt(ss_j / n_j) : kNaN;
  rep.structure_rms = n_s > 0 ? std::sqrt(ss_s / n_s) : kNaN;
  rep.transient_rms = n_t > 0 ? std::sqrt(ss_t / n_t) : kNaN;
  const auto larger = [](const UnexplainedPart& a, const UnexplainedPart& b) { return a.ratio > b.ratio; };
  std::stable_sort(rep.unexplained.begin(), rep.unexplained.end(), larger);
  std::stable_sort(rep.not_judged.begin(), rep.not_judged.end(), larger);
  rep.verdict = rep.unexplained.empty() ? ResidualVerdict::kExplained : ResidualVerdict::kStructureRemains;
  return rep;
}

std::string VerdictReport::heading() const {
  return verdict == ResidualVerdict::kExplained ? "explained to the noise floor" : "structure remains";
}

std::string VerdictReport::text() const {
  const std::string fl = num(floor.rms);
  if (verdict == ResidualVerdict::kExplained) {
    std::string fundamental;
    if (std::isfinite(fundamental_median)) {
      fundamental = "; the sine runs' error at the fundamental (a gain and phase of the α-model): median " +
                    num(fundamental_median) + ", " + std::to_string(fundamental_runs_above) + " of " +
                    std::to_string(fundamental_runs) + " runs above " + num(ratio, "%g") +
                    "× the floor";
    }
    std::string alone;
    if (!not_judged.empty()) {
      alone = "; not judged alone (the sine runs' part that does not repeat is judged by its median " +
              num(cycle_to_cycle) + "): " + std::to_string(not_judged.size()) +
              (not_judged.size() == 1 ? " run above " : " runs above ") + num(ratio, "%g") +
              "× the floor, the largest " + not_judged.front().where + ": RMS " +
              num(not_judged.front().size) + " (" + num(not_judged.front().ratio, "%.0f") + "× the floor)";
    }
    return heading() + ": judged structure RMS " + num(structure_rms) + " = " +
           num(structure_rms / floor.rms, "%.1f") + "× the floor " + fl + fundamental + alone +
           " (transients after starts and reference jumps, not judged: RMS " + num(transient_rms) + ")";
  }
  std::string s = heading() + " (noise floor " + fl + "): ";
  for (std::size_t k = 0; k < unexplained.size() && k < 4; ++k) {
    const UnexplainedPart& u = unexplained[k];
    s += (k ? "; " : "") + u.where + ": RMS " + num(u.size) + " (" + num(u.ratio, "%.0f") + "× the floor)";
  }
  if (unexplained.size() > 4) s += "; and " + std::to_string(unexplained.size() - 4) + " more";
  return s;
}

}  // namespace alphainv
