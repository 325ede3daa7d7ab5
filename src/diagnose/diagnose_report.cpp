#include "alphainv/diagnose/diagnose_report.hpp"
#include "alphainv/diagnose/discovered_term.hpp"
#include "alphainv/diagnose/run_levels.hpp"
#include "diagnose_stages.hpp"

#include <algorithm>
#include <cctype>
#include <cmath>
#include <cstdio>
#include <limits>
#include <sstream>

namespace alphainv {

namespace {

/// x with printf format `f`; "–" for NaN, "∞"/"−∞" for infinities.
std::string fmt(double x, const char* f = "%.4g") {
  if (std::isnan(x)) return "–";
  if (std::isinf(x)) return x > 0 ? "∞" : "−∞";
  char b[64];
  std::snprintf(b, sizeof b, f, x);
  return b;
}

/// The change from `before` to `after` in words: "12.3 % less", "5.9 % more" (the RMS may rise
/// where an effect is named by most runs: named_by_most_runs()).
std::string change_in_words(double before, double after) {
  const double less = 100.0 * (1.0 - after / before);
  return less >= 0.0 ? fmt(less, "%.1f") + " % less" : fmt(-less, "%.1f") + " % more";
}

/// The effects named, joined by ", "; "none" when there are none.
std::string named_text(const std::vector<EffectKind>& named) {
  std::string s;
  for (EffectKind k : named) s += (s.empty() ? "" : ", ") + std::string(effect_name(k));
  return s.empty() ? std::string("none") : s;
}

/// `s` padded with spaces to `width` characters (UTF-8: "–" and "∞" count one), then a space.
std::string column(const std::string& s, std::size_t width) {
  std::size_t chars = 0;
  for (unsigned char ch : s) chars += (ch & 0xC0) != 0x80;
  return s + std::string(chars < width ? width - chars : 0, ' ') + " ";
}

/// A line of full_report()'s candidate table: name, score, folds, RMS after, then the note.
std::string table_line(const std::string& name, const std::string& score, const std::string& fold1,
                       const std::string& fold2, const std::string& after, const std::string& note) {
  return "  " + column(name, 34) + column(score, 11) + column(fold1, 11) + column(fold2, 11) +
         column(after, 11) + note + "\n";
}

std::string candidate_line(const std::string& name, const CandidateScore& c,
                           const std::string& note) {
  return table_line(name, fmt(c.score), fmt(c.fold_scores[0]), fmt(c.fold_scores[1]),
                    fmt(c.error_after), note);
}

/// What a round named: "none", an effect, or a pair "A + B" (the pair fallback).
std::string round_named_text(const DiagnoseRound& rd) {
  std::string s = effect_name(rd.named);
  if (rd.named_second != EffectKind::kNone) s += std::string(" + ") + effect_name(rd.named_second);
  if (rd.took_in != EffectKind::kNone)
    s += std::string(", taking in the ") + effect_name(rd.took_in) + " already in the model";
  if (!rd.rolled_back_why.empty()) return s + "; " + rd.rolled_back_why;  // (the round on trial)
  if (std::isfinite(rd.on_trial_reference_rms))
    s += " on trial (the diagnosis to end below " + fmt(rd.on_trial_reference_rms) + ")";
  if (rd.rolled_back) s += "; rolled back with the round named on trial";
  return s;
}

/// A candidate row is the named one: its effect was named alone (a pair's row is its own).
bool named_alone(const DiagnoseRound& rd, const CandidateScore& c) {
  return c.effect == rd.named && rd.named_second == EffectKind::kNone &&
         std::none_of(rd.pairs.begin(), rd.pairs.end(), [](const PairScore& p) { return p.named; });
}

/// "pair: A + B".
std::string pair_label(const PairScore& p) {
  return std::string("pair: ") + effect_name(p.kinds[0]) + " + " + effect_name(p.kinds[1]);
}

/// Both effects' parameters of a pair's fit.
std::string pair_parameters_text(const PairScore& p) {
  if (!p.fit.ok) return "–";
  return effect_parameters_text(p.fit.effects, p.kinds[0]) + "; " +
         effect_parameters_text(p.fit.effects, p.kinds[1]);
}

/// run_rms[i], NaN when the location has none for run i.
double run_rms_at(const ResidualLocation& loc, std::size_t i) {
  return i < loc.run_rms.size() ? loc.run_rms[i] : std::numeric_limits<double>::quiet_NaN();
}

}  // namespace

const char* termination_name(DiagnoseTermination termination) {
  switch (termination) {
    case DiagnoseTermination::kNoneNamed: return "none named";
    case DiagnoseTermination::kExplained: return "explained";
    case DiagnoseTermination::kMaxEffects: return "max effects";
    case DiagnoseTermination::kInvalidOptions: return "invalid options";
    case DiagnoseTermination::kInvalidInput: return "invalid input";
    case DiagnoseTermination::kFailure: return "failure";
  }
  return "failure";
}

std::string disturbance_markdown(const DisturbanceFinding& f) {
  if (!f.tried) return {};
  std::ostringstream s;
  s << "## External disturbance (a torque of time)\n\nThe equation-error torque residual of the "
       "model given, averaged over time windows; windows far outside its spread (steps, pulses), "
       "then checked by simulating every run with them as a known disturbance: **"
    << (f.named ? "external_disturbance named" : "not named") << "**: " << f.message << ".\n\n";
  std::size_t recorded = 0;
  for (bool b : f.recorded) recorded += b;
  if (recorded > 0) {
    s << "The dataset records a `disturbance_v` column in " << recorded << " of " << f.recorded.size()
      << " runs: a known input, used in every simulation; what is located here is beyond it.\n\n";
  }
  if (f.intervals > 0) {
    if (f.named) {
      s << "The series d̂(t) is in `disturbance.csv` (columns run, t, disturbance_v [command "
           "unit]): added to a run as its `disturbance_v` column it is a known input of "
           "`simulate`/`validate` (plant_input.hpp).\n\n";
    }
    s << "| run | from [s] | to [s] | level d̂ | × spread |\n|---|---|---|---|---|\n";
    std::size_t shown = 0;
    for (std::size_t i = 0; i < f.runs.size(); ++i) {
      for (const DisturbanceInterval& iv : f.runs[i].intervals) {
        if (++shown > 40) break;
        s << "| " << f.run_names[i] << " | " << fmt(iv.start_s, "%.3f") << " | "
          << fmt(iv.end_s, "%.3f") << " | " << fmt(iv.level_v) << " | " << fmt(iv.spreads, "%.1f")
          << " |\n";
      }
    }
    if (shown > 40) s << "\n(" << f.intervals << " intervals in all; every one in disturbance.csv)\n";
    s << "\n";
  }
  // The runs where nothing was located, and why (a run whose residual is not confined to a few
  // windows can hide pulses the other runs show).
  std::ostringstream none;
  std::size_t n_none = 0;
  for (std::size_t i = 0; i < f.runs.size() && i < f.run_names.size(); ++i) {
    if (!f.runs[i].intervals.empty()) continue;
    ++n_none;
    none << "- " << f.run_names[i] << ": "
         << (f.runs[i].message.empty() ? std::string("nothing located") : f.runs[i].message) << "\n";
  }
  if (f.intervals > 0 && n_none > 0) {
    s << "Nothing located in " << n_none << " of " << f.runs.size() << " runs:\n\n" << none.str() << "\n";
  }
  return s.str();
}

std::string disturbance_csv(const DisturbanceFinding& f, const std::vector<DiagnoseRun>& runs) {
  std::ostringstream s;
  s << "run,t,disturbance_v\n";
  char b[96];
  for (std::size_t i = 0; i < f.runs.size() && i < runs.size(); ++i) {
    if (f.runs[i].intervals.empty() || runs[i].data == nullptr) continue;
    const std::vector<double>& t = runs[i].data->t;
    for (std::size_t k = 0; k < t.size() && k < f.runs[i].d_v.size(); ++k) {
      std::snprintf(b, sizeof b, ",%.9g,%.9g\n", t[k], f.runs[i].d_v[k]);
      s << runs[i].name << b;
    }
  }
  return s.str();
}

std::string effect_parameters_text(const Effects& e, EffectKind kind) {
  std::string s;
  // (a friction form's smoothing ε too: a modelling choice, which its fit may take sharper)
  for (const auto& par : effect_parameters(kind, true)) {
    if (par.modelling_choice && par.member != diagnose_detail::friction_smoothing(kind)) continue;
    if (detail::omitted_when_zero(kind, par) && e.*(par.member) == 0.0) continue;
    s += (s.empty() ? "" : ", ") + std::string(par.name) + " = " + fmt(e.*(par.member)) + " " +
         par.unit;
  }
  return s.empty() ? "–" : s;
}

std::string DiagnoseResult::brief_report() const {
  if (!ok) return std::string("not usable (") + termination_name(termination) + "): " + message;
  char b[160];
  std::snprintf(b, sizeof b, "; RMS of theta - theta_sim %s -> %s (%zu runs, %.1f s)",
                fmt(error_before).c_str(), fmt(error_after).c_str(), before.run_rms.size(),
                seconds);
  std::string v;
  if (std::isfinite(noise_floor.rms)) {
    v = verdict.verdict == ResidualVerdict::kExplained ? "; explained to the noise floor"
                                                       : "; structure remains";
  }
  return named_text(effects_named) + b + v;
}

std::vector<NamedEffect> DiagnoseResult::named_in_order() const {
  std::vector<NamedEffect> out;
  if (disturbance.named) out.push_back({EffectKind::kExternalDisturbance, disturbance.error_after, EffectKind::kNone});
  for (std::size_t r = 0; r < rounds.size(); ++r) {
    const DiagnoseRound& rd = rounds[r];
    if (rd.rolled_back) continue;  // (its effects are not in the result)
    for (EffectKind k : {rd.named, rd.named_second}) {  // (a pair: both, the round's error after)
      if (k == EffectKind::kNone) continue;
      if (std::any_of(dropped.begin(), dropped.end(), [&](const DroppedEffect& d) { return d.effect == k; }))
        continue;
      if (std::any_of(rounds.begin() + static_cast<std::ptrdiff_t>(r) + 1, rounds.end(),
                      [&](const DiagnoseRound& later) { return !later.rolled_back && later.took_in == k; }))
        continue;
      if (discovered && discovered->kept && discovered->took_in == k) continue;  // its place taken
      out.push_back({k, rd.error_after, k == rd.named ? rd.took_in : EffectKind::kNone});
    }
  }
  return out;
}

std::string DiagnoseResult::full_report() const {
  std::ostringstream s;
  s << "Diagnose report: " << (ok ? "usable" : "not usable") << "\n"
    << "  termination: " << termination_name(termination) << "\n";
  if (!message.empty()) s << "  message: " << message << "\n";
  s << "  runs: " << before.run_rms.size() << " (" << fit_runs.size() << " to fit and score), "
    << fmt(seconds, "%.1f") << " s\n"
    << "  RMS of θ − θ_sim over all runs: " << fmt(error_before) << " → " << fmt(error_after);
  if (error_before > 0) s << " (" << change_in_words(error_before, error_after) << ")";
  s << "\n  effects named: " << named_text(effects_named) << "\n";
  for (EffectKind k : effects_named)
    s << "    " << effect_name(k) << ": " << effect_parameters_text(effects, k) << "\n";
  s << "  α-model: "
    << (alpha ? "re-identified from the sine runs with the effects" : "the runs' own") << "\n";
  for (std::size_t round = 0; round < rounds.size(); ++round) {
    const DiagnoseRound& rd = rounds[round];
    s << "Round " << round + 1 << ": " << round_named_text(rd) << " (RMS " << fmt(rd.error_before)
      << " → " << fmt(rd.error_after) << ")" << (rd.after_dropping ? " after an effect was dropped" : "") << "\n"
      << table_line("effect (* named)", "score (CV)", "fold 1", "fold 2", "RMS after",
                    "parameters; note");
    for (const CandidateScore& c : rd.candidates) {
      const std::string params = c.ok ? effect_parameters_text(c.effects, c.effect) : "–";
      s << candidate_line(std::string(effect_name(c.effect)) + (named_alone(rd, c) ? " *" : ""),
                          c, params + (c.full_message().empty() ? "" : "; " + c.full_message()));
    }
    if (rd.none_at_winner_breakpoints) {
      s << candidate_line("none at the winner's breakpoints", *rd.none_at_winner_breakpoints,
                          "the winner must beat this too");
    }
    if (rd.none_at_runner_up_breakpoints) {
      s << candidate_line("none at the runner-up's breakpoints", *rd.none_at_runner_up_breakpoints,
                          "the runner-up must beat this too");
    }
    if (rd.none_across_gap) {
      s << candidate_line("none across the α gap", *rd.none_across_gap,
                          "α-model linear across the widest gap of the sine points' α; the winner must beat this too");
    }
    for (const PairScore& p : rd.pairs) {
      s << candidate_line(pair_label(p) + (p.named ? " *" : ""), p.fit,
                          pair_parameters_text(p) + (p.fit.full_message().empty() ? "" : "; " + p.fit.full_message()));
      if (p.none_at_breakpoints) {
        s << candidate_line("none at the pair's breakpoints", *p.none_at_breakpoints,
                            "the pair must beat this too");
      }
    }
  }
  if (discovered) s << "Discovered term: " << discovered->full_report();
  if (run_levels) s << "Friction level run by run: " << run_levels->full_report();
  s << "Before:\n";
  for (const auto& f : before.findings) s << "  - " << f << "\n";
  s << "After:\n";
  for (const auto& f : after.findings) s << "  - " << f << "\n";
  if (disturbance.tried) s << "External disturbance: " << disturbance.message << "\n";
  if (std::isfinite(noise_floor.rms)) s << "Verdict: " << verdict.text() << "\n";
  if (discovered && discovered->kept) s << "  " << discovered_verdict_text(*discovered) << "\n";
  for (const NotSeparable& n : not_separable) s << "Not separable: " << n.message << "\n";
  for (const DroppedEffect& d : dropped) s << "Dropped: " << d.message << "\n";
  return s.str();
}

std::string diagnose_report_markdown(const DiagnoseResult& r, const std::vector<DiagnoseRun>& runs,
                                     const std::string& dataset, const std::string& model_source) {
  std::ostringstream s;
  s << "# omni_fit diagnose report\n\nDataset: `" << dataset << "` (" << runs.size()
    << " runs; model: " << model_source << "). Candidates fitted and scored on "
    << r.fit_runs.size() << " runs; wall time " << fmt(r.seconds, "%.1f") << " s.\n\n";
  s << "## Where the model was wrong (before)\n\n";
  for (const auto& f : r.before.findings) s << "- " << f << "\n";
  s << "\n## Candidates\n\nEach candidate effect was searched with the α-model re-identified "
       "from the sine runs with the effect in the plant input (when the model has an α-model and "
       "the dataset sine runs), then fitted by output error together with the α-model's "
       "coefficient factors, and scored by 2-fold cross-validation (fitted on one half of each "
       "fit window, RMS error on the other half). An effect is named only when its score is at "
       "least 10 % below that of `none` in both folds, the error over all runs drops by 5 % or "
       "more, and it also beats `none` refitted at its α-model's breakpoints. See "
       "docs/diagnose.md.\n\n";
  for (std::size_t round = 0; round < r.rounds.size(); ++round) {
    const DiagnoseRound& rd = r.rounds[round];
    s << "### Round " << round + 1 << ": " << round_named_text(rd) << " (RMS error "
      << fmt(rd.error_before) << " → " << fmt(rd.error_after) << ")"
      << (rd.after_dropping ? ", after an effect was dropped (below): in the place it freed" : "") << "\n\n"
      << "| effect | score (CV RMS) | fold 1 | fold 2 | RMS after, all runs | parameters | note |\n"
         "|---|---|---|---|---|---|---|\n";
    for (const auto& c : rd.candidates) {
      s << "| " << (named_alone(rd, c) ? "**" + std::string(effect_name(c.effect)) + "**"
                                       : std::string(effect_name(c.effect)))
        << " | " << fmt(c.score) << " | " << fmt(c.fold_scores[0]) << " | "
        << fmt(c.fold_scores[1]) << " | " << fmt(c.error_after) << " | "
        << (c.ok ? effect_parameters_text(c.effects, c.effect) : "–") << " | " << c.full_message() << " |\n";
    }
    if (rd.none_at_winner_breakpoints) {
      const CandidateScore& t = *rd.none_at_winner_breakpoints;
      s << "| none at the winner's breakpoints | " << fmt(t.score) << " | " << fmt(t.fold_scores[0])
        << " | " << fmt(t.fold_scores[1]) << " | " << fmt(t.error_after)
        << " | – | the winner must beat this too |\n";
    }
    if (rd.none_at_runner_up_breakpoints) {
      const CandidateScore& t = *rd.none_at_runner_up_breakpoints;
      s << "| none at the runner-up's breakpoints | " << fmt(t.score) << " | " << fmt(t.fold_scores[0])
        << " | " << fmt(t.fold_scores[1]) << " | " << fmt(t.error_after)
        << " | – | the runner-up (tried when the winner was not named) must beat this too |\n";
    }
    if (rd.none_across_gap) {
      const CandidateScore& t = *rd.none_across_gap;
      s << "| none across the α gap | " << fmt(t.score) << " | " << fmt(t.fold_scores[0]) << " | "
        << fmt(t.fold_scores[1]) << " | " << fmt(t.error_after)
        << " | – | the α-model linear across the widest gap of the sine points' α; the winner must "
           "beat this too |\n";
    }
    // The pair fallback (no single effect named while structure remained): each pair fitted
    // jointly, and `none` at the breakpoints of the best.
    for (const PairScore& p : rd.pairs) {
      const std::string label = pair_label(p);
      s << "| " << (p.named ? "**" + label + "**" : label) << " | " << fmt(p.fit.score) << " | "
        << fmt(p.fit.fold_scores[0]) << " | " << fmt(p.fit.fold_scores[1]) << " | "
        << fmt(p.fit.error_after) << " | " << pair_parameters_text(p) << " | "
        << (p.afresh ? "started from both searched together from nothing; " : "") << p.fit.full_message()
        << " |\n";
      if (p.none_at_breakpoints) {
        const CandidateScore& t = *p.none_at_breakpoints;
        s << "| none at the pair's breakpoints | " << fmt(t.score) << " | " << fmt(t.fold_scores[0])
          << " | " << fmt(t.fold_scores[1]) << " | " << fmt(t.error_after)
          << " | – | the pair must beat this too |\n";
      }
    }
    if (!rd.pairs.empty()) {
      s << "\nNo single effect was named while structure remained, so pairs of candidates were "
           "fitted jointly (two effects can mask each other): pairs of the best candidates, the "
           "second searched with the first's fit, and every pair of the scanned effects searched "
           "together from nothing (a product of their scans); the "
        << diagnose_detail::kMaxPairFits
        << " of lowest search RMS were fitted; the best, when it beat none, was fitted again with "
           "each member in the forms that generalise it (a Coulomb friction as Stribeck, "
           "asymmetric or position-dependent friction), kept when their extra parameters earn "
           "their place; and a pair is named when it passes the tests of a single effect.\n";
    }
    if (rd.none_refitted) {
      s << "\nNothing was named, but the model's own refitted (" << rd.none_refit_how
        << ") explains the data to the noise floor where the model as it came did not: the "
           "diagnosis goes on with it (RMS error "
        << fmt(rd.error_before) << " → " << fmt(rd.error_after) << ").\n";
    }
    s << "\n";
  }
  if (!r.dropped.empty()) {
    s << "### Dropped after the rounds\n\nEach effect the rounds named was checked again: the named "
         "effects refitted without it, cross-validated, against the same with it.\n\n";
    for (const DroppedEffect& d : r.dropped) s << "- " << d.message << "\n";
    s << "\n";
  }
  s << disturbance_markdown(r.disturbance);
  if (r.discovered) {
    const DiscoveredTermResult& d = *r.discovered;
    s << "## Discovered term\n\nStructure remained after the named effects: the torque the model "
         "leaves was regressed sparsely on a library of functions of θ and θ̇ (cross-validated over "
         "runs, the fewest terms within one standard error of the best), then refined by output "
         "error (docs/diagnose.md).\n\n"
      << d.brief_report() << "\n\n";
    if (!d.terms.empty()) {
      s << "| term | function | coefficient | ± SE | regression | ± SE |\n|---|---|---|---|---|---|\n";
      for (const DiscoveredTermEntry& t : d.terms)
        s << "| " << t.name << " | " << t.formula << " | " << fmt(t.coefficient) << " | "
          << fmt(t.standard_error) << " | " << fmt(t.regression_coefficient) << " | "
          << fmt(t.regression_standard_error) << " |\n";
      s << "\n";
    }
  }
  if (r.run_levels && r.run_levels->ok) {
    const RunLevelsResult& rl = *r.run_levels;
    s << "## The friction level run by run\n\nStructure remained: the model's friction level was "
         "fitted run by run on one half of each fit window and judged on the other (run_levels.hpp).\n\n"
      << rl.brief_report() << "\n\n";
    if (rl.varies) {
      s << "| run | level × | ± SE | RMS before | RMS after |\n|---|---|---|---|---|\n";
      for (const RunLevel& x : rl.runs)
        s << "| " << x.name << " | " << fmt(x.factor) << " | " << fmt(x.standard_error) << " | "
          << fmt(x.rms_before) << " | " << fmt(x.rms_after) << " |\n";
      s << "\n";
    }
  }
  s << "## The gap before and after\n\nRMS of θ − θ_sim over all runs: **" << fmt(r.error_before)
    << " → " << fmt(r.error_after) << "**";
  if (r.error_before > 0) s << " (" << change_in_words(r.error_before, r.error_after) << ")";
  s << ".\n\n| run | RMS before | RMS after | change |\n|---|---|---|---|\n";
  for (std::size_t i = 0; i < runs.size(); ++i) {
    const double b = run_rms_at(r.before, i), a = run_rms_at(r.after, i);
    s << "| " << runs[i].name << " | " << fmt(b) << " | " << fmt(a) << " | "
      << (b > 0 ? fmt(100.0 * (a / b - 1.0), "%+.1f") + " %" : "–") << " |\n";
  }
  s << "\n## Where the model is wrong now (after)\n\n";
  for (const auto& f : r.after.findings) s << "- " << f << "\n";
  if (!std::isfinite(r.noise_floor.rms)) return s.str();  // not judged
  s << "\n## Verdict\n\nNoise floor (the residual's white part, from its second differences): "
    << fmt(r.noise_floor.white) << "; the sine runs' steady state not repeating from cycle to "
    << "cycle: " << fmt(r.noise_floor.cycle_to_cycle) << ".\n\n";
  {
    const std::string text = r.verdict.text();  // (it starts with the heading: in bold, capitalised)
    std::string heading = r.verdict.heading();
    heading[0] = static_cast<char>(std::toupper(static_cast<unsigned char>(heading[0])));
    s << "**" << heading << "**" << text.substr(heading.size()) << "\n";
  }
  if (r.discovered && r.discovered->kept) s << "\n" << discovered_verdict_text(*r.discovered) << "\n";
  if (!r.not_separable.empty()) {
    s << "\nNot separable on these data (separability.hpp): named and not ruled out either.\n\n";
    for (const NotSeparable& n : r.not_separable) s << "- " << n.message << "\n";
  }
  if (!r.verdict.unexplained.empty()) {
    s << "\n| where | RMS | × floor |\n|---|---|---|\n";
    for (const UnexplainedPart& u : r.verdict.unexplained)
      s << "| " << u.where << " | " << fmt(u.size) << " | " << fmt(u.ratio, "%.1f") << " |\n";
  }
  if (!r.verdict.not_judged.empty()) {
    s << "\nAbove " << fmt(r.verdict.ratio, "%g") << "× the floor but not judged alone (the sine "
      << "runs' part that does not repeat is judged by its median over them, "
      << fmt(r.verdict.cycle_to_cycle) << "):\n\n| where | RMS | × floor |\n|---|---|---|\n";
    for (const UnexplainedPart& u : r.verdict.not_judged)
      s << "| " << u.where << " | " << fmt(u.size) << " | " << fmt(u.ratio, "%.1f") << " |\n";
  }
  return s.str();
}

}  // namespace alphainv
