#pragma once
// A live source: a camera (`camera:N`, `/dev/videoN`) or a stream (`rtsp://`, `http://`,
// `https://`), read through OpenCV's video I/O. A robot's camera does not wait for the engine: a
// thread keeps grabbing, each frame placedb takes is the newest one, and frames that arrive while
// the engine is busy are dropped and counted. `max_fps` caps the rate at which frames are taken
// (0: as fast as the engine goes). The source ends when the stream does, on Ctrl-C (the mapping
// loop's interrupt flag, polled while waiting for a frame), or when nothing came for the read
// timeout (endProblem() says so). An MJPEG stream over HTTP is read part by part by placedb
// (mjpeg_stream.h): a part that is no image is a bad frame and the stream goes on.
#include <memory>
#include <string>

#include "sources/image_source.h"

namespace placedb::cli {

// True for the names above.
bool isLiveSource(const std::string& source);

// Throws placedb::Error(kIo) when the camera or stream cannot be opened.
std::unique_ptr<ImageSource> openLiveSource(const std::string& source, double max_fps);

}  // namespace placedb::cli
