#pragma once
// placedb.Error and one subclass per exit-code category. Every exception carries the numbers
// the command line would exit with (`exit_code`) and its category name (`category`), so a
// script can branch on the kind of failure the same way a shell script does on `$?`.
#include <pybind11/pybind11.h>

namespace placedb::python {

// Adds placedb.Error, InvalidArgument, IoError, MapRefused, MapBusy, ReadOnly, DiskFull,
// VocabularyRefused, StorageError and InternalError to the module, and translates
// placedb::Error (and OpenCV's and the standard library's exceptions) into them.
void registerErrors(pybind11::module_& module);

}  // namespace placedb::python
