#include "apps/python/python_signals.h"

namespace py = pybind11;

namespace ieslam {

SignalPoll::~SignalPoll() {
  if (type_ == nullptr) return;
  py::gil_scoped_acquire acquire;
  Py_XDECREF(type_);
  Py_XDECREF(value_);
  Py_XDECREF(traceback_);
}

std::function<bool()> SignalPoll::Poll() {
  return [this] {
    py::gil_scoped_acquire acquire;
    if (type_ != nullptr) return true;
    if (PyErr_CheckSignals() == 0) return false;
    PyErr_Fetch(&type_, &value_, &traceback_);
    return true;
  };
}

void SignalPoll::RaiseIfStopped() {
  if (type_ == nullptr) return;
  PyErr_Restore(type_, value_, traceback_);
  type_ = value_ = traceback_ = nullptr;
  throw py::error_already_set();
}

}  // namespace ieslam
