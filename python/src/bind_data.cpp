/// \file bind_data.cpp
/// The formats (alphainv::data) in Python: Dataset (alphainv-dataset/1) with its runs as numpy
/// views, Model (model.json, alphainv-model/1), the joint model at a pose, and the generator of
/// datasets from the virtual Omni (experiment_plan.hpp).

#include <filesystem>
#include <string>
#include <utility>
#include <vector>

#include "alphainv/data/dataset.hpp"
#include "alphainv/data/model_file.hpp"
#include "alphainv/simulate/experiment_plan.hpp"
#include "alphainv/simulate/model_simulation.hpp"
#include "alphainv/simulate/simulate.hpp"
#include "bindings.hpp"

namespace alphainv::python {

namespace {

/// Every column of a run: t, r, theta, v, then the extra columns by name (views, no copies).
py::dict run_columns(RunData& d, py::handle owner) {
  py::dict c;
  c["t"] = view(d.t, owner);
  c["r"] = view(d.r, owner);
  c["theta"] = view(d.theta, owner);
  c["v"] = view(d.v, owner);
  for (auto& [name, col] : d.extra_columns) c[py::str(name)] = view(col, owner);
  return c;
}

std::optional<double> optional_of(py::handle h, const char* field) {
  if (h.is_none()) return std::nullopt;
  try {
    return h.cast<double>();
  } catch (const py::cast_error&) {
    throw Error("expected a number or None", {}, 0, field);
  }
}

/// A one-run dataset holding a run made from arrays.
DatasetPtr make_run(py::handle t, py::handle r, py::handle theta, py::handle v, const std::string& kind,
                    const std::string& file, py::handle freq_hz, py::handle amplitude_rad,
                    py::handle gamma1_deg, py::handle gamma2_deg, py::handle controller,
                    py::handle columns) {
  auto d = std::make_shared<DatasetData>();
  RunData run;
  run.t = to_vector(t, "t");
  run.r = to_vector(r, "r");
  run.theta = to_vector(theta, "theta");
  run.v = to_vector(v, "v");
  if (!columns.is_none()) {
    for (auto item : columns.cast<py::dict>()) {
      const std::string name = py::str(item.first);
      run.extra_columns[name] = to_vector(item.second, name);
    }
  }
  for (const auto* col : {&run.r, &run.theta, &run.v}) {
    if (col->size() != run.t.size()) {
      throw Error("expected " + std::to_string(run.t.size()) + " samples like t, found " +
                      std::to_string(col->size()),
                  {}, 0, col == &run.r ? "r" : col == &run.theta ? "theta" : "v");
    }
  }
  for (const auto& [name, col] : run.extra_columns) {
    if (col.size() != run.t.size()) {
      throw Error("expected " + std::to_string(run.t.size()) + " samples like t, found " +
                      std::to_string(col.size()),
                  {}, 0, name);
    }
  }
  RunInfo info;
  info.file = file;
  info.kind = kind;
  info.freq_hz = optional_of(freq_hz, "freq_hz");
  info.amplitude_rad = optional_of(amplitude_rad, "amplitude_rad");
  info.gamma1_deg = optional_of(gamma1_deg, "gamma1_deg");
  info.gamma2_deg = optional_of(gamma2_deg, "gamma2_deg");
  if (!controller.is_none()) info.controller = controller.cast<Controller>();
  d->index.runs.push_back(std::move(info));
  d->runs.push_back(std::move(run));
  return d;
}

/// A dataset of runs (copied) with dataset-wide settings.
DatasetPtr make_dataset(const std::vector<RunView>& runs, py::handle sample_rate_hz,
                        py::handle controller, const std::string& position_unit,
                        const std::string& command_unit, const std::string& joint) {
  auto d = std::make_shared<DatasetData>();
  d->index.position_unit = position_unit;
  d->index.command_unit = command_unit;
  d->index.joint = joint;
  d->index.sample_rate_hz = optional_of(sample_rate_hz, "sample_rate_hz");
  if (!controller.is_none()) d->index.controller = controller.cast<Controller>();
  for (const RunView& r : runs) {
    RunInfo info = r.info();
    // A run without its own law takes the dataset's (as the reader applies it).
    if (info.controller == kUnstatedController) info.controller = d->index.controller;
    d->index.runs.push_back(std::move(info));
    d->runs.push_back(r.data());
  }
  // Checks every key as the reader would (throws naming it).
  (void)parse_dataset_index(format_dataset_index(d->index), "dataset");
  return d;
}

std::vector<RunView> run_views(const DatasetPtr& d) {
  std::vector<RunView> out;
  for (std::size_t i = 0; i < d->runs.size(); ++i) out.push_back(RunView{d, i});
  return out;
}

PoseSetPoint pose_of(py::handle h, const char* field) {
  try {
    const auto p = h.cast<std::pair<double, double>>();
    return PoseSetPoint{p.first, p.second};
  } catch (const py::cast_error&) {
    throw Error("expected a pose (gamma1_deg, gamma2_deg)", {}, 0, field);
  }
}

/// Dataset.generate: the paper's plan on the virtual Omni with the options given.
DatasetPtr generate(std::uint64_t seed, py::kwargs kwargs) {
  Options o(std::move(kwargs), "Dataset.generate");
  ExperimentPlanOptions plan = paper_plan_options(seed);
  py::object pose = o.raw("pose");
  if (!pose.is_none()) {
    if (py::isinstance<py::int_>(pose)) {
      const auto poses = paper_sine_poses();
      const long k = pose.cast<long>();
      if (k < 0 || static_cast<std::size_t>(k) >= poses.size())
        throw Error("expected 0.." + std::to_string(poses.size() - 1) + ", found " + std::to_string(k), {}, 0, "pose");
      plan.sine_poses = {poses[static_cast<std::size_t>(k)]};
    } else {
      plan.sine_poses = {pose_of(pose, "pose")};
    }
    plan.square_poses = plan.sine_poses;
  }
  py::object poses = o.raw("poses");
  if (!poses.is_none()) {
    plan.sine_poses.clear();
    for (auto p : poses.cast<py::sequence>()) plan.sine_poses.push_back(pose_of(p, "poses"));
    plan.square_poses = plan.sine_poses;
  }
  o.get_effects("effects", plan.plant.effects);
  o.get("noise_std_rad", plan.plant.measurement.noise_std_rad);
  o.get("quantisation_rad", plan.plant.measurement.quantisation_rad);
  o.get("sine_freqs_hz", plan.sine_freqs_hz);
  o.get("sine_amplitude_rad", plan.sine_amplitude_rad);
  o.get("sine_settle_s", plan.sine_settle_s);
  o.get("sine_steady_s", plan.sine_steady_s);
  o.get("square_freq_hz", plan.square_freq_hz);
  o.get("square_amplitude_rad", plan.square_amplitude_rad);
  o.get("square_duration_s", plan.square_duration_s);
  o.get("truth_columns", plan.record_truth_columns);
  o.get("inertia", plan.plant.inertia);
  o.get("alpha_model", plan.plant.alpha_model);
  o.get("controller", plan.controller);
  o.get("joint", plan.joint);
  o.finish();
  ExperimentPlan laid_out = make_experiment_plan(plan);  // validates, naming the field
  auto d = std::make_shared<DatasetData>();
  {
    py::gil_scoped_release release;
    GeneratedDataset g = generate_dataset(laid_out);
    d->index = std::move(g.index);
    d->runs = std::move(g.runs);
  }
  return d;
}

py::dict pose_dict(const PoseLinearModel& p) {
  py::dict d;
  d["gamma1_deg"] = optional_number(p.gamma1_deg);
  d["gamma2_deg"] = optional_number(p.gamma2_deg);
  d["c_linear"] = p.c_linear;
  d["beta_tilde_linear"] = p.beta_tilde_linear;
  return d;
}

PoseLinearModel pose_from(py::handle h) {
  py::dict d = h.cast<py::dict>();
  PoseLinearModel p;
  if (d.contains("gamma1_deg")) p.gamma1_deg = optional_of(d["gamma1_deg"], "poses.gamma1_deg");
  if (d.contains("gamma2_deg")) p.gamma2_deg = optional_of(d["gamma2_deg"], "poses.gamma2_deg");
  p.c_linear = d["c_linear"].cast<double>();
  p.beta_tilde_linear = d["beta_tilde_linear"].cast<double>();
  return p;
}

}  // namespace

DatasetPtr read_dataset_folder(const std::string& dir) {
  auto d = std::make_shared<DatasetData>();
  py::gil_scoped_release release;
  d->index = read_dataset_index(dir);
  for (std::size_t i = 0; i < d->index.runs.size(); ++i) d->runs.push_back(read_run(d->index, i));
  return d;
}

DatasetPtr dataset_argument(py::handle obj) {
  if (py::isinstance<DatasetData>(obj)) return obj.cast<DatasetPtr>();
  if (py::isinstance<py::str>(obj) || py::hasattr(obj, "__fspath__")) {
    return read_dataset_folder(py::str(py::module_::import("os").attr("fspath")(obj)));
  }
  throw Error("expected an alphainv.Dataset or a dataset folder (str or path)", {}, 0, "dataset");
}

void bind_data(py::module_& m) {
  // --- Run --------------------------------------------------------------------------------------
  py::class_<RunView>(m, "Run", R"(One run of a dataset: the columns t [s], r, theta [position unit],
v [command unit] and any extra ones as numpy arrays that share the dataset's memory (no copies),
and its entry of dataset.json (kind, frequency, amplitude, pose, controller).)")
      .def(py::init([](py::handle t, py::handle r, py::handle theta, py::handle v, const std::string& kind,
                       const std::string& file, py::handle freq_hz, py::handle amplitude_rad,
                       py::handle gamma1_deg, py::handle gamma2_deg, py::handle controller,
                       py::handle columns) {
             return RunView{make_run(t, r, theta, v, kind, file, freq_hz, amplitude_rad, gamma1_deg,
                                     gamma2_deg, controller, columns),
                            0};
           }),
           py::arg("t"), py::arg("r"), py::arg("theta"), py::arg("v"), py::kw_only(),
           py::arg("kind") = "other", py::arg("file") = "runs/run.csv", py::arg("freq_hz") = py::none(),
           py::arg("amplitude_rad") = py::none(), py::arg("gamma1_deg") = py::none(),
           py::arg("gamma2_deg") = py::none(), py::arg("controller") = py::none(),
           py::arg("columns") = py::none(),
           "A run from arrays (copied into the run). kind: sine, square, step, chirp or other; "
           "columns: extra columns by name.")
      .def_property_readonly("t", [](py::object self) { return view(self.cast<RunView&>().data().t, self); },
                             "time [s]")
      .def_property_readonly("r", [](py::object self) { return view(self.cast<RunView&>().data().r, self); },
                             "reference [position unit]")
      .def_property_readonly(
          "theta", [](py::object self) { return view(self.cast<RunView&>().data().theta, self); },
          "measured position [position unit]")
      .def_property_readonly("v", [](py::object self) { return view(self.cast<RunView&>().data().v, self); },
                             "command [command unit]")
      .def_property_readonly(
          "columns", [](py::object self) { return run_columns(self.cast<RunView&>().data(), self); },
          "every column by name (numpy views)")
      .def("to_frame", [](py::object self) {
             return data_frame(run_columns(self.cast<RunView&>().data(), self), "Run.to_frame()");
           },
           "The columns as a pandas DataFrame (needs pandas).")
      .def("__len__", [](const RunView& r) { return r.data().size(); })
      .def_property_readonly("file", [](const RunView& r) { return r.info().file; })
      .def_property_readonly("kind", [](const RunView& r) { return r.info().kind; })
      .def_property_readonly("freq_hz", [](const RunView& r) { return optional_number(r.info().freq_hz); })
      .def_property_readonly("amplitude_rad", [](const RunView& r) { return optional_number(r.info().amplitude_rad); })
      .def_property_readonly("gamma1_deg", [](const RunView& r) { return optional_number(r.info().gamma1_deg); })
      .def_property_readonly("gamma2_deg", [](const RunView& r) { return optional_number(r.info().gamma2_deg); })
      .def_property_readonly("controller", [](const RunView& r) { return r.info().controller; })
      .def_property_readonly(
          "extra", [](const RunView& r) {
            return r.info().extra_json.empty() ? py::object(py::dict()) : json_loads(r.info().extra_json);
          },
          "the run's object in dataset.json as a dict (keys this library does not know too)")
      .def("__repr__", [](const RunView& r) {
        return "Run('" + r.info().file + "', kind='" + r.info().kind + "', " +
               std::to_string(r.data().size()) + " samples)";
      });

  // --- Dataset ----------------------------------------------------------------------------------
  py::class_<DatasetData, DatasetPtr>(m, "Dataset", R"(A dataset in the interchange format
alphainv-dataset/1 (docs/dataset-format.md): dataset.json and its run CSV files, read whole.)")
      .def(py::init(&make_dataset), py::arg("runs"), py::kw_only(), py::arg("sample_rate_hz") = py::none(),
           py::arg("controller") = py::none(), py::arg("position_unit") = "rad",
           py::arg("command_unit") = "V", py::arg("joint") = "",
           "A dataset of Run objects (copied). Runs without their own controller get this one.")
      .def_static("read", [](py::handle path) { return dataset_argument(path); }, py::arg("path"),
                  "Reads dataset.json and every run (the hardened reader; GIL released). Raises "
                  "alphainv.Error naming the file, line and column of anything malformed.")
      .def(
          "write",
          [](const DatasetData& d, py::handle path) {
            const std::string dir = py::str(py::module_::import("os").attr("fspath")(path));
            py::gil_scoped_release release;
            write_dataset(dir, d.index, d.runs);
          },
          py::arg("path"),
          "Writes the dataset into a folder, every file atomically, dataset.json last.")
      .def_static("generate", &generate, py::arg("seed") = 1,
                  R"(A dataset of the virtual Omni (the C++ generator, as omni_gen paper): the
paper's plan (Tables 1-2: 9 sine frequencies 1.5-7 Hz at 9 poses, 0.25 Hz square waves at 25
poses, +-0.07 rad, kp = 2 at 1 kHz) with the bundled effects (Coulomb 0.004 V, quantisation
1.5e-4 rad, noise 5e-5 rad). Options: pose (0..8 of the sine poses, or (g1, g2) set point
[deg]: its sine and square runs only), poses (a list of set points), effects (the plant's
effects, replacing the bundled Coulomb friction), noise_std_rad, quantisation_rad,
sine_freqs_hz, sine_amplitude_rad, sine_settle_s, sine_steady_s, square_freq_hz,
square_amplitude_rad, square_duration_s, truth_columns, inertia (InertiaModel), alpha_model
(AlphaModel), controller, joint. dataset.extra["truth"] holds every plant parameter.)")
      .def_property_readonly("runs", &run_views, "the runs (views)")
      .def("__len__", [](const DatasetData& d) { return d.runs.size(); })
      .def("__getitem__",
           [](const DatasetPtr& d, long i) {
             const long n = static_cast<long>(d->runs.size());
             if (i < 0) i += n;
             if (i < 0 || i >= n) throw py::index_error("run index out of range");
             return RunView{d, static_cast<std::size_t>(i)};
           })
      .def("__iter__", [](const DatasetPtr& d) { return py::iter(py::cast(run_views(d))); })
      .def_property_readonly("dir", [](const DatasetData& d) { return d.index.dir.string(); },
                             "the folder it was read from ('' when made in memory)")
      .def_property_readonly("joint", [](const DatasetData& d) { return d.index.joint; })
      .def_property_readonly("position_unit", [](const DatasetData& d) { return d.index.position_unit; })
      .def_property_readonly("command_unit", [](const DatasetData& d) { return d.index.command_unit; })
      .def_property_readonly("sample_rate_hz", [](const DatasetData& d) { return optional_number(d.index.sample_rate_hz); })
      .def_property_readonly("controller", [](const DatasetData& d) { return d.index.controller; })
      .def_property_readonly(
          "extra", [](const DatasetData& d) {
            return d.index.extra_json.empty() ? py::object(py::dict()) : json_loads(d.index.extra_json);
          },
          "dataset.json without `runs` as a dict (source, generator, truth, ...)")
      .def(
          "to_frame",
          [](const DatasetData& d) {
            py::list file, kind, freq, amp, g1, g2, kp, n;
            for (std::size_t i = 0; i < d.runs.size(); ++i) {
              const RunInfo& r = d.index.runs[i];
              file.append(r.file), kind.append(r.kind), freq.append(optional_number(r.freq_hz));
              amp.append(optional_number(r.amplitude_rad)), g1.append(optional_number(r.gamma1_deg));
              g2.append(optional_number(r.gamma2_deg)), kp.append(r.controller.kp), n.append(d.runs[i].size());
            }
            py::dict c;
            c["file"] = file, c["kind"] = kind, c["freq_hz"] = freq, c["amplitude_rad"] = amp;
            c["gamma1_deg"] = g1, c["gamma2_deg"] = g2, c["kp"] = kp, c["samples"] = n;
            return data_frame(c, "Dataset.to_frame()");
          },
          "One row per run (file, kind, freq_hz, amplitude_rad, gamma1_deg, gamma2_deg, kp, "
          "samples) as a pandas DataFrame.")
      .def("__repr__",
           [](const DatasetData& d) {
             return "Dataset(" + std::to_string(d.runs.size()) + " runs" +
                    (d.index.dir.empty() ? "" : ", '" + d.index.dir.string() + "'") + ")";
           })
      .def(py::pickle(
          [](py::object self) {  // the index as dataset.json text, the columns as numpy arrays
            const DatasetData& d = self.cast<const DatasetData&>();
            py::list runs;
            for (std::size_t i = 0; i < d.runs.size(); ++i) {
              RunData& r = const_cast<RunData&>(d.runs[i]);
              runs.append(run_columns(r, self));
            }
            return py::make_tuple(format_dataset_index(d.index), d.index.dir.string(), runs);
          },
          [](py::tuple t) {
            auto d = std::make_shared<DatasetData>();
            d->index = parse_dataset_index(t[0].cast<std::string>(), t[1].cast<std::string>());
            for (auto cols : t[2].cast<py::list>()) {
              RunData r;
              for (auto item : cols.cast<py::dict>()) {
                const std::string name = py::str(item.first);
                std::vector<double> v = to_vector(item.second, name);
                if (name == "t") r.t = std::move(v);
                else if (name == "r") r.r = std::move(v);
                else if (name == "theta") r.theta = std::move(v);
                else if (name == "v") r.v = std::move(v);
                else r.extra_columns[name] = std::move(v);
              }
              d->runs.push_back(std::move(r));
            }
            return d;
          }));

  // --- the joint model at a pose ----------------------------------------------------------------
  py::class_<JointModelAtPose>(m, "JointModel", R"(The joint model at one pose (simulate.hpp):
I, C_linear and beta~_linear (24)-(25), the alpha-model and the effects.)")
      .def_readwrite("use_alpha", &JointModelAtPose::use_alpha)
      .def_readwrite("inertia", &JointModelAtPose::inertia, "I at the pose")
      .def_readwrite("c_linear", &JointModelAtPose::c_linear, "C_linear(I) [1/s]")
      .def_readwrite("beta_tilde_linear", &JointModelAtPose::beta_tilde_linear, "beta~_linear(I)")
      .def_readwrite("alpha_model", &JointModelAtPose::alpha)
      .def_readwrite("effects", &JointModelAtPose::effects)
      .def("damping", py::vectorize([](JointModelAtPose j, double a) {
             return j.use_alpha ? j.alpha.damping(a, j.inertia) : j.c_linear;
           }),
           py::arg("alpha"), "C(alpha, I) [1/s] (the linear model's C when use_alpha is false)")
      .def("beta_tilde", py::vectorize([](JointModelAtPose j, double a) {
             return j.use_alpha ? j.alpha.beta_tilde(a, j.inertia) : j.beta_tilde_linear;
           }),
           py::arg("alpha"), "beta~(alpha, I)");

  // --- Model (model.json) -----------------------------------------------------------------------
  py::class_<ModelFile>(m, "Model", R"(A fitted model as model.json holds it (alphainv-model/1):
the inertia model (6) with C0_bar (24)-(26), per-pose linear models (22), the alpha-model
(38)-(42) with standard errors, the effects, the controller and the simulation mode.)")
      .def(py::init([](py::object alpha_model, py::object linear, py::object controller, py::object effects,
                       double loop_period_s, const std::string& position_unit, const std::string& command_unit,
                       py::object poses) {
             ModelFile f;
             if (!alpha_model.is_none()) f.alpha = alpha_model.cast<AlphaModel>(), f.has_alpha_model = true;
             if (!linear.is_none()) f.linear = linear.cast<LinearModel>(), f.has_inertia_model = true;
             if (!controller.is_none()) f.controller = controller.cast<Controller>();
             f.effects = effects_from(effects);
             f.loop_period_s = loop_period_s;
             f.position_unit = position_unit, f.command_unit = command_unit;
             if (!poses.is_none()) for (auto p : poses.cast<py::sequence>()) f.poses.push_back(pose_from(p));
             f.tool_version = "alphainv 0.1.0 (python)";
             (void)parse_model_file(format_model_file(f), "Model");  // refuses what the reader would
             return f;
           }),
           py::kw_only(), py::arg("alpha_model") = py::none(), py::arg("linear") = py::none(),
           py::arg("controller") = py::none(), py::arg("effects") = py::none(),
           py::arg("loop_period_s") = 0.0, py::arg("position_unit") = "rad", py::arg("command_unit") = "V",
           py::arg("poses") = py::none())
      .def_static(
          "read", [](py::handle path) { return read_model_file(py::str(py::module_::import("os").attr("fspath")(path)).cast<std::string>()); },
          py::arg("path"), "Reads model.json; raises alphainv.Error naming the file and the key.")
      .def("write", [](const ModelFile& f, py::handle path) {
             write_model_file(py::str(py::module_::import("os").attr("fspath")(path)).cast<std::string>(), f);
           },
           py::arg("path"), "Writes model.json atomically and durably.")
      .def_static("from_json", [](const std::string& text) { return parse_model_file(text, "model.json"); },
                  py::arg("text"))
      .def("to_json", &format_model_file, "The JSON text write() writes.")
      .def("to_dict", [](const ModelFile& f) { return json_loads(format_model_file(f)); },
           "model.json as a dict.")
      .def_readwrite("has_alpha_model", &ModelFile::has_alpha_model)
      .def_readwrite("alpha_model", &ModelFile::alpha)
      .def_readwrite("has_inertia_model", &ModelFile::has_inertia_model)
      .def_readwrite("linear", &ModelFile::linear)
      .def_readwrite("controller", &ModelFile::controller)
      .def_readwrite("effects", &ModelFile::effects)
      .def_readwrite("loop_period_s", &ModelFile::loop_period_s)
      .def_readwrite("position_unit", &ModelFile::position_unit)
      .def_readwrite("command_unit", &ModelFile::command_unit)
      .def_readonly("tool_version", &ModelFile::tool_version)
      .def_readonly("dataset_hash", &ModelFile::dataset_hash)
      .def_readonly("dataset_path", &ModelFile::dataset_path)
      .def_readonly("notes", &ModelFile::notes)
      .def_property_readonly("linear_se", [](const ModelFile& f) {
        return to_array(std::vector<double>(f.linear_se.begin(), f.linear_se.end()));
      }, "standard errors of I_base, I1, I2, I3, gamma_offs [rad], C0_bar (NaN: unknown)")
      .def_property_readonly("c_n1_se", [](const ModelFile& f) {
        return to_array(std::vector<double>(f.c_n1_se.begin(), f.c_n1_se.begin() + static_cast<std::ptrdiff_t>(f.alpha.n_breakpoints)));
      })
      .def_property_readonly("beta_n1_se", [](const ModelFile& f) { return f.beta_n1_se; })
      .def_property_readonly("poses", [](const ModelFile& f) {
        py::list out;
        for (const PoseLinearModel& p : f.poses) out.append(pose_dict(p));
        return out;
      }, "per-pose linear models (22): gamma1_deg, gamma2_deg, c_linear, beta_tilde_linear")
      .def("at_pose",
           [](const ModelFile& f, py::handle g1, py::handle g2, bool use_alpha) {
             std::string note;
             JointModelAtPose j = model_at(f, optional_of(g1, "gamma1_deg"), optional_of(g2, "gamma2_deg"),
                                           use_alpha, &note);
             return py::make_tuple(j, note);
           },
           py::arg("gamma1_deg") = py::none(), py::arg("gamma2_deg") = py::none(), py::arg("use_alpha") = true,
           "(JointModel, note): the model at the measured pose [deg] (model_at: eq. (6) with an "
           "inertia model, else the nearest pose's linear model).")
      .def("__repr__", [](const ModelFile& f) {
        return std::string("Model(") + (f.has_alpha_model ? "alpha-model" : "no alpha-model") +
               (f.has_inertia_model ? ", inertia model" : "") + ", " + std::to_string(f.poses.size()) +
               " poses, effects: " + effects_text(f.effects) + ")";
      })
      .def(py::pickle([](const ModelFile& f) { return format_model_file(f); },
                      [](const std::string& s) { return parse_model_file(s, "model.json"); }));
}

}  // namespace alphainv::python
