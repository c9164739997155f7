#pragma once
// Ctrl-C (SIGINT), SIGTERM and SIGHUP ask a long command to stop after the frame in flight, so the
// map is closed cleanly. The handler only sets a flag; the command polls it between frames.

namespace placedb::cli {

void installInterruptHandlers();
bool interruptRequested();
// "SIGINT", "SIGTERM" or "SIGHUP": the first of them that came.
const char* interruptSignalName();

}  // namespace placedb::cli
