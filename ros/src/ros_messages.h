#pragma once
// The engine's results as placedb_msgs messages (ros/msg, ros/srv).
#include <cstdint>
#include <optional>
#include <string>

#include <placedb_msgs/FrameStatus.h>
#include <placedb_msgs/LoopClosure.h>
#include <placedb_msgs/Query.h>
#include <ros/time.h>
#include <sensor_msgs/CompressedImage.h>
#include <sensor_msgs/Image.h>

#include "placedb/map.h"
#include "sources/image_message.h"

namespace placedb::ros_node {

// A stamp in ns since the epoch as a ros::Time; zero when there is none.
ros::Time rosTime(const std::optional<std::int64_t>& stamp_ns);

placedb_msgs::LoopClosure closureMessage(const FrameResult& result, const std::string& frame_id);
placedb_msgs::FrameStatus statusMessage(const FrameResult& result, const std::string& frame_id,
                                        std::int64_t dropped);
void fillQueryResponse(const QueryResult& result, placedb_msgs::Query::Response& response);

// A message's ROS 1 serialization, which decodeImageMessage reads: a service's image goes
// through the same decoding as a topic's and a bag's.
cli::DecodedImage decodeImage(const sensor_msgs::Image& image);
cli::DecodedImage decodeImage(const sensor_msgs::CompressedImage& image);

}  // namespace placedb::ros_node
