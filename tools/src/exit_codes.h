#pragma once
// The exit status of every placedb subcommand, one per placedb::ErrorCode, so scripts can branch
// on the kind of failure. The numbers are published: never renumber them.
#include <string>

#include "placedb/error.h"

namespace placedb::cli {

constexpr int kExitOk = 0;
constexpr int kExitUsage = 2;  // CLI11 usage errors share the number of kInvalidArgument
// `map` of a live source that stopped sending for its read timeout: the session is closed with
// every frame kept, as at the source's end, but the end was not the stream's. Not an error.
constexpr int kExitSourceStalled = 14;

int exitCodeFor(ErrorCode code);

// The table printed in the epilog of `placedb --help`.
std::string exitCodeTable();

// Prints "placedb: error: <message>" as one line on stderr (newlines in the message are folded).
void printError(const std::string& message);
void printWarning(const std::string& message);
// "placedb: note: <message>": what a figure means, not a problem.
void printNote(const std::string& message);

}  // namespace placedb::cli
