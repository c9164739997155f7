#include "errors.h"

#include <exception>
#include <opencv2/core.hpp>
#include <string>
#include <vector>

#include "exit_codes.h"
#include "placedb/error.h"

namespace py = pybind11;

namespace placedb::python {
namespace {

struct Category {
  ErrorCode code;
  const char* class_name;
  const char* category;
};

const std::vector<Category>& categories() {
  static const std::vector<Category> table = {
      {ErrorCode::kInvalidArgument, "InvalidArgument", "invalid_argument"},
      {ErrorCode::kIo, "IoError", "io"},
      {ErrorCode::kMapRefused, "MapRefused", "map_refused"},
      {ErrorCode::kMapBusy, "MapBusy", "map_busy"},
      {ErrorCode::kReadOnly, "ReadOnly", "read_only"},
      {ErrorCode::kDiskFull, "DiskFull", "disk_full"},
      {ErrorCode::kVocabularyRefused, "VocabularyRefused", "vocabulary_refused"},
      {ErrorCode::kStorage, "StorageError", "storage"},
      {ErrorCode::kInternal, "InternalError", "internal"},
      {ErrorCode::kServerUnreachable, "ServerUnreachable", "server_unreachable"},
      {ErrorCode::kAuthRefused, "AuthRefused", "auth_refused"},
      {ErrorCode::kServerLost, "ServerLost", "server_lost"},
  };
  return table;
}

// The classes live as long as the interpreter: held by the module and by these handles, which
// are never released (a static py::object would be destroyed after the interpreter is gone).
std::vector<PyObject*>& classes() {
  static std::vector<PyObject*> objects(categories().size(), nullptr);
  return objects;
}

PyObject* classFor(ErrorCode code) {
  for (std::size_t i = 0; i < categories().size(); ++i)
    if (categories()[i].code == code) return classes()[i];
  return classFor(ErrorCode::kInternal);
}

PyObject* newClass(const std::string& name, PyObject* base, int exit_code, const char* category) {
  py::dict attributes;
  attributes["exit_code"] = exit_code;
  attributes["category"] = category;
  PyObject* cls = PyErr_NewException(name.c_str(), base, attributes.ptr());
  if (!cls) throw py::error_already_set();
  return cls;
}

}  // namespace

void registerErrors(py::module_& module) {
  PyObject* base = newClass("placedb.Error", PyExc_RuntimeError,
                            cli::exitCodeFor(ErrorCode::kInternal), "internal");
  module.attr("Error") = py::handle(base);
  for (std::size_t i = 0; i < categories().size(); ++i) {
    const Category& c = categories()[i];
    classes()[i] = newClass(std::string("placedb.") + c.class_name, base, cli::exitCodeFor(c.code),
                            c.category);
    module.attr(c.class_name) = py::handle(classes()[i]);
  }
  py::register_exception_translator([](std::exception_ptr failure) {
    try {
      if (failure) std::rethrow_exception(failure);
    } catch (const Error& e) {
      PyErr_SetString(classFor(e.code()), e.what());
    } catch (const cv::Exception& e) {
      PyErr_SetString(classFor(ErrorCode::kInternal), (std::string("OpenCV: ") + e.what()).c_str());
    }
  });
}

}  // namespace placedb::python
