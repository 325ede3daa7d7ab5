/// \file module.cpp
/// The compiled part of the Python package `alphainv` (`alphainv._alphainv`): the error
/// translation and the shared helpers of bindings.hpp. The bindings themselves are in
/// bind_model.cpp (core), bind_data.cpp (formats, generator) and bind_work.cpp (simulate, fit,
/// diagnose, validate). There is no second implementation: every call goes to the C++ library.

#include <string>

#include "bindings.hpp"

namespace alphainv::python {

py::array_t<double> view(std::vector<double>& v, py::handle owner) {
  return py::array_t<double>({static_cast<py::ssize_t>(v.size())}, {sizeof(double)}, v.data(), owner);
}

py::array_t<double> to_array(const std::vector<double>& v) {
  return py::array_t<double>(static_cast<py::ssize_t>(v.size()), v.data());
}

std::vector<double> to_vector(py::handle obj, const std::string& field) {
  py::array_t<double, py::array::c_style | py::array::forcecast> a;
  try {
    a = py::array_t<double, py::array::c_style | py::array::forcecast>::ensure(obj);
  } catch (const py::error_already_set&) {
  }
  if (!a || a.ndim() != 1) {
    throw Error("expected a 1-D array of numbers, found " +
                    std::string(py::str(py::type::of(obj).attr("__name__"))),
                {}, 0, field);
  }
  return std::vector<double>(a.data(), a.data() + a.shape(0));
}

py::object optional_number(const std::optional<double>& x) {
  return x ? py::object(py::float_(*x)) : py::object(py::none());
}

py::object data_frame(const py::dict& columns, const char* what) {
  py::module_ pandas;
  try {
    pandas = py::module_::import("pandas");
  } catch (const py::error_already_set&) {
    throw py::import_error(std::string(what) + " needs pandas (Debian: python3-pandas); the "
                           "columns are numpy arrays without it");
  }
  return pandas.attr("DataFrame")(columns);
}

py::object json_loads(const std::string& text) { return py::module_::import("json").attr("loads")(text); }

py::object Options::raw(const char* name) {
  known_.insert(name);
  if (!kwargs_.contains(name)) return py::none();
  used_.insert(name);
  return kwargs_[name];
}

void Options::get_effects(const char* name, Effects& target) {
  const py::object value = raw(name);
  if (!value.is_none()) target = effects_from(value, name);
}

void Options::finish() const {
  for (auto item : kwargs_) {
    const std::string key = py::str(item.first);
    if (used_.count(key)) continue;
    std::string known;
    for (const std::string& k : known_) known += (known.empty() ? "" : ", ") + k;
    throw Error(call_ + ": unknown option; expected one of " + known, {}, 0, key);
  }
}

}  // namespace alphainv::python

PYBIND11_MODULE(_alphainv, m) {
  namespace py = pybind11;
  using alphainv::python::bind_data;
  using alphainv::python::bind_model;
  using alphainv::python::bind_work;
  m.doc() = "alphainv: the alpha-invariant nonlinear damping model of joints with friction "
            "(C++ library bindings; import alphainv, not this module)";
  // alphainv.Error (a ValueError) carries the C++ error's message, file, line and field.
  static py::handle error_type = py::object(py::module_::import("alphainv._error").attr("Error")).release();
  py::register_exception_translator([](std::exception_ptr p) {
    try {
      if (p) std::rethrow_exception(p);
    } catch (const alphainv::Error& e) {
      py::object inst = py::reinterpret_borrow<py::object>(error_type)(
          e.message(), e.file(), e.line(), e.field(), e.what());
      PyErr_SetObject(error_type.ptr(), inst.ptr());
    }
  });
  m.attr("Error") = py::reinterpret_borrow<py::object>(error_type);
  bind_model(m);
  bind_data(m);
  bind_work(m);
}
