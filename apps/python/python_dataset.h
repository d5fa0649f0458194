// `ieslam.load_dataset` and its Dataset and Frame classes: a dataset's frames as NumPy
// arrays, loaded one at a time as the library loads them (core/dataset.h).
#pragma once

#include <pybind11/pybind11.h>

namespace ieslam {

void BindDataset(pybind11::module_& m);

}  // namespace ieslam
