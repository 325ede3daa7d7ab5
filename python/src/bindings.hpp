#pragma once
/// \file bindings.hpp
/// Shared pieces of the Python module `alphainv` (pybind11): the dataset holder the Dataset and
/// Run objects share, numpy views and conversions, keyword options. Internal to python/src/.

#include <pybind11/numpy.h>
#include <pybind11/pybind11.h>
#include <pybind11/stl.h>

#include <cstddef>
#include <memory>
#include <optional>
#include <set>
#include <string>
#include <vector>

#include "alphainv/data/dataset.hpp"
#include "alphainv/error.hpp"
#include "alphainv/model/effects.hpp"

namespace alphainv::python {

namespace py = pybind11;

/// A dataset's index and its run data, owned together: the Dataset object and every Run view
/// (and every numpy array viewing a column) hold a reference to it.
struct DatasetData {
  Dataset index;
  std::vector<RunData> runs;  ///< runs[i] is the data of index.runs[i]
};
using DatasetPtr = std::shared_ptr<DatasetData>;

/// Run `index` of a shared dataset. Its column arrays share the dataset's memory.
struct RunView {
  DatasetPtr owner;
  std::size_t index = 0;
  RunData& data() const { return owner->runs.at(index); }
  RunInfo& info() const { return owner->index.runs.at(index); }
};

/// A writable numpy view of `v` (no copy), keeping `owner` alive while the array lives.
py::array_t<double> view(std::vector<double>& v, py::handle owner);
/// A numpy copy of `v`.
py::array_t<double> to_array(const std::vector<double>& v);
/// The numbers of a 1-D array-like, as a vector; throws alphainv::Error naming `field`.
std::vector<double> to_vector(py::handle obj, const std::string& field);
/// None or the value.
py::object optional_number(const std::optional<double>& x);
/// A pandas DataFrame of `columns` when pandas is installed; otherwise ImportError saying so.
py::object data_frame(const py::dict& columns, const char* what);
/// json.loads(text).
py::object json_loads(const std::string& text);

/// Effects from None, an Effects, a spec string ("coulomb_friction:coulomb_v=0.004"), a list of
/// spec strings, or a dict {effect name: {parameter: value}} / {parameter: value}. Throws
/// alphainv::Error naming `field`.
Effects effects_from(py::handle obj, const std::string& field = "effects");
/// {effect name: {parameter: value}} of the active effects (modelling choices included).
py::dict effects_dict(const Effects& e);

/// The keyword options of one call, read one by one; finish() refuses what is left, naming it.
class Options {
 public:
  Options(py::kwargs kwargs, std::string call) : kwargs_(std::move(kwargs)), call_(std::move(call)) {}
  /// Sets `target` from option `name` when given (None leaves it); throws alphainv::Error naming
  /// the option when the value has the wrong type.
  template <class T>
  bool get(const char* name, T& target) {
    known_.insert(name);
    if (!kwargs_.contains(name)) return false;
    const py::object value = kwargs_[name];
    used_.insert(name);
    if (value.is_none()) return false;
    try {
      target = value.cast<T>();
    } catch (const py::cast_error&) {
      throw Error(call_ + ": expected " + py::type_id<T>() + ", found " +
                      std::string(py::str(py::type::of(value).attr("__name__"))),
                  {}, 0, name);
    }
    return true;
  }
  /// Sets `target` from an effects option (effects_from()) when given.
  void get_effects(const char* name, Effects& target);
  /// The raw value of option `name`, or None.
  py::object raw(const char* name);
  /// Throws alphainv::Error naming the first option that no get() asked for.
  void finish() const;

 private:
  py::kwargs kwargs_;
  std::string call_;
  std::set<std::string> known_, used_;
};

/// A dataset argument: a Dataset, or a path (str, os.PathLike) read with Dataset.read.
DatasetPtr dataset_argument(py::handle obj);
/// Reads a dataset folder (index and every run) with the GIL released.
DatasetPtr read_dataset_folder(const std::string& dir);

void bind_model(py::module_& m);
void bind_data(py::module_& m);
void bind_work(py::module_& m);

}  // namespace alphainv::python
