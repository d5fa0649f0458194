#include "apps/python/python_dataset.h"

#include <memory>
#include <string>

#include <pybind11/eigen.h>
#include <pybind11/numpy.h>
#include <pybind11/stl.h>

#include "apps/python/python_convert.h"
#include "core/dataset.h"
#include "selection/pipeline/run_options.h"

namespace py = pybind11;

namespace ieslam {
namespace {

// A loaded frame: colour H x W x 3 uint8 RGB (the library's BGR converted), depth H' x W'
// float32 metres in the range imager's grid (0: no measurement).
struct PythonFrame {
  FrameInfo info;
  py::array_t<uint8_t> colour;
  py::array_t<float> depth;
};

PythonFrame LoadFrame(const Dataset& dataset, int i) {
  if (i < 0) i += dataset.size();
  if (i < 0 || i >= dataset.size()) throw py::index_error("frame index out of range");
  Frame frame;
  {
    py::gil_scoped_release release;
    frame = dataset.Load(i);
  }
  return {frame.info, ColourToArray(frame.colour), DepthToArray(frame.depth)};
}

// The dataset options as `ieslam run` takes them: format and calib, and the others of the
// registry's dataset section as keyword arguments (first=, last=, stride=, ...).
std::shared_ptr<Dataset> LoadDataset(const std::string& directory, const std::string& format,
                                     const py::object& calib, const py::kwargs& options) {
  RunOptions run_options;
  py::dict section;
  section["format"] = format;
  if (!calib.is_none()) section["calib"] = calib;
  for (const auto& item : options) section[item.first] = item.second;
  py::dict dict;
  dict["dataset"] = section;
  ApplyOptionsDict(RunOptions::Registry(), dict, "load_dataset", &run_options);
  std::string why;
  if (!run_options.dataset_options.Check(&why)) throw ConfigError(why);
  py::gil_scoped_release release;
  return OpenDataset(directory, run_options.dataset_options);
}

}  // namespace

void BindDataset(py::module_& m) {
  py::class_<PythonFrame>(m, "Frame", "One frame of a dataset, loaded.")
      .def_property_readonly("index", [](const PythonFrame& f) { return f.info.index; })
      .def_property_readonly("source_index",
                             [](const PythonFrame& f) { return f.info.source_index; })
      .def_property_readonly("timestamp", [](const PythonFrame& f) { return f.info.timestamp; })
      .def_readonly("colour", &PythonFrame::colour, "H x W x 3 uint8, RGB")
      .def_readonly("depth", &PythonFrame::depth, "H x W float32, metres; 0 = no measurement")
      .def_property_readonly(
          "T_w_c_gt",
          [](const PythonFrame& f) -> py::object {
            if (!f.info.T_w_c_gt) return py::none();
            return py::cast(Eigen::Matrix4d(f.info.T_w_c_gt->matrix()));
          },
          "ground truth camera-to-world 4 x 4, or None")
      .def("__repr__", [](const PythonFrame& f) {
        return "<ieslam.Frame " + std::to_string(f.info.index) +
               " t=" + std::to_string(f.info.timestamp) + ">";
      });

  py::class_<Dataset, std::shared_ptr<Dataset>>(m, "Dataset",
                                                "A dataset's frames, loaded one at a time.")
      .def("__len__", &Dataset::size)
      .def("__getitem__", &LoadFrame, py::arg("i"))
      .def("__iter__",
           [](std::shared_ptr<Dataset> d) {
             // A generator over the frames, each loaded when it is reached.
             py::list indices;
             for (int i = 0; i < d->size(); ++i) indices.append(i);
             return py::module_::import("builtins")
                 .attr("map")(py::cpp_function([d](int i) { return LoadFrame(*d, i); }), indices)
                 .attr("__iter__")();
           })
      .def_property_readonly("format", &Dataset::format)
      .def_property_readonly("directory", &Dataset::directory)
      .def_property_readonly("total_frames", &Dataset::total_frames)
      .def_property_readonly("has_ground_truth", &Dataset::has_ground_truth)
      .def_property_readonly("calibration_path", &Dataset::calibration_path)
      .def_property_readonly("warnings", &Dataset::warnings)
      .def_property_readonly("timestamps",
                             [](const Dataset& d) {
                               py::array_t<double> t(d.size());
                               auto a = t.mutable_unchecked<1>();
                               for (int i = 0; i < d.size(); ++i) a(i) = d.info(i).timestamp;
                               return t;
                             })
      .def_property_readonly(
          "ground_truth", [](const Dataset& d) { return TrajectoryToArray(d.GroundTruth()); },
          "N x 8 (t x y z qx qy qz qw) of the frames with ground truth")
      .def_property_readonly(
          "K", [](const Dataset& d) { return Eigen::Matrix3d(d.rig().colour.K()); },
          "the colour camera's 3 x 3 intrinsics")
      .def("__repr__", [](const Dataset& d) {
        return "<ieslam.Dataset " + d.format() + " '" + d.directory() + "', " +
               std::to_string(d.size()) + " frames>";
      });

  m.def("load_dataset", &LoadDataset, py::arg("directory"), py::arg("format") = "auto",
        py::arg("calib") = py::none(),
        "Opens a dataset (tum, 7scenes, pair or auto); keyword arguments set the other\n"
        "dataset options (first=, last=, stride=, ...). Raises DataError or ConfigError.");
}

}  // namespace ieslam
