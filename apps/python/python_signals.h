// Ctrl-C for the library's long calls from Python: the library's `stop` hook asks Python's
// signal handlers (PyErr_CheckSignals, with the GIL taken back for the call) and says stop
// once one raised; the call's caller raises that exception after the library returned.
#pragma once

#include <functional>

#include <pybind11/pybind11.h>

namespace ieslam {

class SignalPoll {
 public:
  SignalPoll() = default;
  ~SignalPoll();  // drops an exception not raised
  SignalPoll(const SignalPoll&) = delete;
  SignalPoll& operator=(const SignalPoll&) = delete;

  // The hook, for a call made with the GIL released; callable from any thread (only the main
  // thread's calls run the handlers, as Python runs them only there). It refers to *this.
  std::function<bool()> Poll();
  // With the GIL held: throws the exception a handler raised (pybind11 gives it to Python).
  void RaiseIfStopped();

 private:
  // The raised exception, taken out of the thread's error indicator so that the library
  // runs on with none set; guarded by the GIL.
  PyObject* type_ = nullptr;
  PyObject* value_ = nullptr;
  PyObject* traceback_ = nullptr;
};

}  // namespace ieslam
