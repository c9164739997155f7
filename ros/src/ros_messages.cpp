#include "ros_messages.h"

#include <ros/serialization.h>

#include <vector>

namespace placedb::ros_node {
namespace {

placedb_msgs::FrameRef frameMessage(const FrameRef& frame) {
  placedb_msgs::FrameRef out;
  out.session = frame.session_id;
  out.index = frame.source_index;
  out.stamp = rosTime(frame.stamp_ns);
  out.path = frame.source_path;
  return out;
}

void fillPose(const std::optional<storage::ClosurePose>& pose, std::uint8_t& has_pose,
              geometry_msgs::Pose& out) {
  has_pose = pose.has_value();
  if (!pose) return;
  out.orientation.w = pose->qw;
  out.orientation.x = pose->qx;
  out.orientation.y = pose->qy;
  out.orientation.z = pose->qz;
  out.position.x = pose->tx;
  out.position.y = pose->ty;
  out.position.z = pose->tz;
}

template <class Message>
cli::DecodedImage decodeSerialized(const Message& message, cli::ImageMessageKind kind) {
  std::vector<std::uint8_t> bytes(ros::serialization::serializationLength(message));
  ros::serialization::OStream stream(bytes.data(), static_cast<std::uint32_t>(bytes.size()));
  ros::serialization::serialize(stream, message);
  return cli::decodeImageMessage(bytes.data(), bytes.size(), kind, cli::WireFormat::kRos1);
}

}  // namespace

ros::Time rosTime(const std::optional<std::int64_t>& stamp_ns) {
  ros::Time time;
  if (stamp_ns && *stamp_ns > 0) time.fromNSec(static_cast<std::uint64_t>(*stamp_ns));
  return time;
}

placedb_msgs::LoopClosure closureMessage(const FrameResult& result, const std::string& frame_id) {
  const Hypothesis& h = result.hypothesis;
  placedb_msgs::LoopClosure out;
  out.header.stamp = rosTime(result.stamp_ns);
  out.header.frame_id = frame_id;
  out.session = result.session_id;
  out.index = result.source_index;
  out.location = h.location_id;
  // framesOf() lists a place's frames in the order they were mapped: the first made the place.
  for (const FrameRef& frame : h.frames) out.frames.push_back(frameMessage(frame));
  if (!out.frames.empty()) out.matched = out.frames.front();
  out.score = h.score;
  out.posterior = h.posterior;
  out.inliers = h.inliers;
  out.matches = h.matches;
  fillPose(h.pose, out.has_pose, out.pose);
  return out;
}

placedb_msgs::FrameStatus statusMessage(const FrameResult& result, const std::string& frame_id,
                                        std::int64_t dropped) {
  placedb_msgs::FrameStatus out;
  out.header.stamp = rosTime(result.stamp_ns);
  out.header.frame_id = frame_id;
  out.session = result.session_id;
  out.index = result.source_index;
  out.outcome = static_cast<std::uint8_t>(result.outcome);
  out.location = result.location_id;
  out.closure = result.hypothesis.accepted;
  out.dropped = static_cast<std::uint64_t>(dropped);
  return out;
}

void fillQueryResponse(const QueryResult& result, placedb_msgs::Query::Response& response) {
  response.verdict = toString(result.verdict);
  response.searched = static_cast<std::uint32_t>(result.searched);
  response.checked = static_cast<std::uint32_t>(result.checked);
  for (const QueryMatch& match : result.matches) {
    placedb_msgs::QueryMatch out;
    out.location = match.location_id;
    out.tier = storage::toString(match.tier);
    out.similarity = match.similarity;
    out.code_similarity = match.code_similarity;
    out.inliers = match.inliers;
    out.verified = match.verified;
    for (const FrameRef& frame : match.frames) out.frames.push_back(frameMessage(frame));
    fillPose(match.pose, out.has_pose, out.pose);
    response.matches.push_back(std::move(out));
  }
}

cli::DecodedImage decodeImage(const sensor_msgs::Image& image) {
  return decodeSerialized(image, cli::ImageMessageKind::kRaw);
}

cli::DecodedImage decodeImage(const sensor_msgs::CompressedImage& image) {
  return decodeSerialized(image, cli::ImageMessageKind::kCompressed);
}

}  // namespace placedb::ros_node
