#pragma once
// Rows of a map's SQL views for Python, read straight from the file so that every column the
// view has (the schema documents them in schema/SCHEMA.md) reaches the caller.
#include <pybind11/pybind11.h>

#include <string>

namespace placedb::python {

// The rows of v_loop_closures as a list of dicts, column name -> value. Opens the file
// read-only. Throws placedb::Error(kIo) when it is missing, kMapRefused when it has no such view.
pybind11::list loopClosureRows(const std::string& path);

}  // namespace placedb::python
