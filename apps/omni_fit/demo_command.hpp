#pragma once
#include <CLI/CLI.hpp>

namespace omni_fit {

/// The options of `omni_fit demo`.
struct DemoCommandOptions {
  double gamma1_deg = 60.08;    ///< pose angle γ1 [deg]
  double gamma2_deg = 87.00;    ///< pose angle γ2 [deg]
  double amplitude_rad = 0.07;  ///< reference amplitude [rad]
  double kp = 2.0;              ///< proportional gain [V/rad]
  bool cvode = false;           ///< SUNDIALS CVODE instead of the fixed-point scheme (44)-(46)
};

/// Adds the `demo` subcommand to `app`, its options bound to `options` (which must outlive the
/// parse).
CLI::App* add_demo_subcommand(CLI::App& app, DemoCommandOptions& options);

/// `omni_fit demo`: the paper's α-invariant and linear models at one pose on the paper's plan
/// (the Table 1 sine sweep, a 0.25 Hz square wave), printed as a table. Returns the process exit
/// code (0 ok, 3 a simulation failed).
int run_demo(const DemoCommandOptions& options);

}  // namespace omni_fit
