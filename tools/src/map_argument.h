#pragma once
// A map named on the command line: a file, or a map on a PostgreSQL server named by a libpq URI
// (postgresql://... or postgres://...). Every command that takes a map asks here, so a URI is
// never treated as a file and its password never reaches a message, a log or the map itself.
#include <CLI/CLI.hpp>

#include <string>

namespace placedb::cli {

// For add_option(...)->transform(): a URI that holds a password (user:password@ or
// password=...) loses it, and the password goes to libpq through PGPASSWORD instead (libpq
// reads it when the URI gives none). Files pass unchanged.
CLI::Validator mapArgument();

// Overwrites in place, with one 'x' a character, every password that a server URI among the
// process's arguments holds (user:password@, password=...), as psql and mysql do: `ps` and
// /proc/PID/cmdline then never show it. main() calls it first, with its own argv, after copying
// the arguments it parses. An argument may also hold a URI after '=' (--opt=postgresql://...).
void hidePasswordsInArguments(int argc, char** argv);

// kIo "map M does not exist" for a missing file; nothing for a URI (opening it says whether the
// database holds a map).
void requireExistingMap(const std::string& map);

// True when opening `map` read-write would create it: a missing or empty file. Always false for
// a URI: a database is never created or deleted by placedb.
bool mapFileIsNew(const std::string& map);

}  // namespace placedb::cli
