#pragma once
// Ctrl-C (SIGINT), SIGTERM and SIGHUP ask a long command to stop after the frame in flight, so the
// map is closed cleanly. The handler only sets a flag; the command polls it between frames.

namespace placedb::cli {

void installInterruptHandlers();
bool interruptRequested();

}  // namespace placedb::cli
