// placedb_node: a ROS 1 node that maps an image topic into a placedb map, publishes every
// accepted loop closure and answers queries. `placedb_node --help` and docs/ros.md say how.
//
// It is `placedb map` over a topic: the mapping loop is the command line's (runMapping: resume,
// the per-frame log, a lost server waited for, the clean close), fed by a TopicSource, so that
// the node decides exactly as `placedb map` on a bag of the same messages.
#include <fmt/format.h>
#include <ros/ros.h>
#include <sensor_msgs/CameraInfo.h>
#include <topic_tools/shape_shifter.h>

#include <chrono>
#include <csignal>
#include <cstdio>
#include <cstring>
#include <memory>
#include <mutex>
#include <optional>
#include <string>
#include <thread>

#include "commands/mapping_run.h"
#include "exit_codes.h"
#include "interrupt.h"
#include "placedb/error.h"
#include "placedb/version.h"
#include "query_service.h"
#include "ros_messages.h"
#include "topic_source.h"

namespace placedb::ros_node {
namespace {

constexpr const char* kHelp = R"(placedb_node {}: maps a ROS image topic into a placedb map.

Usage: rosrun-style, with ROS remappings and private parameters:
  placedb_node image:=/camera/image_raw _map:=/data/run.placedb [_param:=value ...]
  roslaunch ros/launch/placedb.launch map:=/data/run.placedb image:=/camera/image_raw

Subscribes:
  image         sensor_msgs/Image or sensor_msgs/CompressedImage (remap it; for compressed
                images remap to the .../compressed topic); mono8, mono16, bgr8, rgb8, bgra8,
                rgba8, JPEG or PNG, decoded exactly as `placedb map` decodes a bag's
  camera_info   sensor_msgs/CameraInfo: the intrinsics (K) of a new session, from the first one
                that arrives before it begins (see ~camera_info_wait)
Publishes:
  ~loop_closures  placedb_msgs/LoopClosure, each accepted loop closure: the frame's stamp, the
                  matched place and its first frame's stamp, score, inliers, and the relative
                  pose when the session has intrinsics
  ~frames         placedb_msgs/FrameStatus, each frame once committed (index, outcome, dropped)
Service:
  ~query          placedb_msgs/Query: an image in, `placedb query`'s verdict and matches out
Parameters:
  ~map (string, required)     the map: a file (absolute: roslaunch runs nodes in ~/.ros) or a
                              postgresql:// URI of a map on a server
  ~settings (dict or string)  engine settings, {{t_loop: 0.1}} or "t_loop=0.1 wm_max=300"
                              (`placedb settings` lists them); win over ~config and ~preset
  ~config, ~preset, ~calibration (string)  as `placedb map --config/--preset/--calibration`
  ~camera_info_wait (double, 5)  seconds to wait for camera_info before a new session begins
                              without intrinsics (0: do not wait nor use camera_info);
                              ~calibration or fx..cy in ~settings win over camera_info
  ~drop_frames (bool, true)   keep up with the camera: frames that arrive while the engine is
                              busy are dropped and counted; false maps every frame in order
                              (a bag played faster than the engine goes)
  ~log (string)               the per-frame CSV log of `placedb map --log`
  ~source (string, "ros:" + the image topic)  the session's source name: a start resumes the
                              map's last session over it (give each robot of a fleet its own)
  ~new_session (bool, false)  begin a new session instead of resuming
  ~server_wait (double, 60)   a map on a server: seconds to wait for a lost server
  ~quiet (bool, false)        no progress lines on stderr

Every start resumes the last session over ~source where it stopped, whether the node was shut
down (SIGINT, as roslaunch does: the frame in flight is finished and the session closed) or
killed; frames still queued at shutdown are not mapped. Errors are one line on stderr and the
exit status of `placedb map`:
{})";

struct NodeParameters {
  std::string map_path;
  cli::SettingsInput settings;
  bool intrinsics_given = false;  // ~calibration or fx..cy in ~settings
  double camera_info_wait = 5;
  bool drop_frames = true;
  std::string log_path;
  std::string source;
  bool new_session = false;
  double server_wait = 60;
  bool quiet = false;
};

std::string settingText(XmlRpc::XmlRpcValue& value, const std::string& key) {
  switch (value.getType()) {
    case XmlRpc::XmlRpcValue::TypeBoolean:
      return static_cast<bool>(value) ? "true" : "false";
    case XmlRpc::XmlRpcValue::TypeInt:
      return std::to_string(static_cast<int>(value));
    case XmlRpc::XmlRpcValue::TypeDouble:
      return fmt::format("{}", static_cast<double>(value));
    case XmlRpc::XmlRpcValue::TypeString:
      return static_cast<std::string>(value);
    default:
      throw Error(ErrorCode::kInvalidArgument,
                  fmt::format("parameter ~settings: {} is not a number, a boolean or a text", key));
  }
}

// "fx=1 fy=2" or {fx: 1, fy: 2}: key=value assignments, as --set takes them.
std::vector<std::string> settingsAssignments(const ros::NodeHandle& private_nh) {
  std::vector<std::string> out;
  XmlRpc::XmlRpcValue value;
  if (!private_nh.getParam("settings", value)) return out;
  if (value.getType() == XmlRpc::XmlRpcValue::TypeString) {
    std::string text = value, word;
    for (std::size_t at = 0; at <= text.size(); ++at) {
      if (at == text.size() || std::isspace(static_cast<unsigned char>(text[at]))) {
        if (!word.empty()) out.push_back(word);
        word.clear();
      } else {
        word += text[at];
      }
    }
    return out;
  }
  if (value.getType() != XmlRpc::XmlRpcValue::TypeStruct)
    throw Error(ErrorCode::kInvalidArgument,
                "parameter ~settings must be a dictionary ({t_loop: 0.1}) or a text "
                "(\"t_loop=0.1 wm_max=300\")");
  for (auto& [key, setting] : value) out.push_back(key + "=" + settingText(setting, key));
  return out;
}

NodeParameters readParameters(const ros::NodeHandle& private_nh, const std::string& image_topic) {
  NodeParameters p;
  if (!private_nh.getParam("map", p.map_path) || p.map_path.empty())
    throw Error(ErrorCode::kInvalidArgument,
                "parameter ~map is not set: the map file or postgresql:// URI to map into "
                "(e.g. _map:=/data/run.placedb; placedb_node --help)");
  private_nh.getParam("config", p.settings.config_file);
  private_nh.getParam("preset", p.settings.preset);
  private_nh.getParam("calibration", p.settings.calibration_file);
  p.settings.assignments = settingsAssignments(private_nh);
  p.intrinsics_given = !p.settings.calibration_file.empty();
  for (const auto& assignment : p.settings.assignments)
    for (const char* key : {"fx=", "fy=", "cx=", "cy="})
      if (assignment.rfind(key, 0) == 0) p.intrinsics_given = true;
  private_nh.param("camera_info_wait", p.camera_info_wait, p.camera_info_wait);
  private_nh.param("drop_frames", p.drop_frames, p.drop_frames);
  private_nh.param("log", p.log_path, p.log_path);
  private_nh.param("source", p.source, "ros:" + image_topic);
  private_nh.param("new_session", p.new_session, p.new_session);
  private_nh.param("server_wait", p.server_wait, p.server_wait);
  private_nh.param("quiet", p.quiet, p.quiet);
  if (p.camera_info_wait < 0 || p.server_wait < 0)
    throw Error(ErrorCode::kInvalidArgument,
                "parameters ~camera_info_wait and ~server_wait are seconds, 0 or more");
  return p;
}

// Intrinsics from camera_info's K as settings, before the user's own (which win).
std::vector<std::string> intrinsicsOf(const sensor_msgs::CameraInfo& info) {
  if (info.K[0] <= 0 || info.K[4] <= 0) return {};  // an uncalibrated camera
  return {fmt::format("fx={}", info.K[0]), fmt::format("fy={}", info.K[4]),
          fmt::format("cx={}", info.K[2]), fmt::format("cy={}", info.K[5])};
}

int run() {
  ros::NodeHandle nh, private_nh("~");
  cli::installInterruptHandlers();  // SIGINT finishes the frame in flight and closes the session
  const auto stop = [] { return cli::interruptRequested() || !ros::ok(); };
  const std::string image_topic = nh.resolveName("image");
  NodeParameters params = readParameters(private_nh, image_topic);

  auto source = std::make_shared<TopicSource>(params.source, params.drop_frames, stop);
  bool warned_type = false;
  // With drop_frames the mailbox drops and counts; roscpp's own queue only has to absorb a
  // burst while the callback runs, which copies one message. Without, nothing is dropped.
  ros::Subscriber image_sub = nh.subscribe<topic_tools::ShapeShifter>(
      "image", params.drop_frames ? 100 : 0,
      [source, &warned_type, image_topic](const topic_tools::ShapeShifter::ConstPtr& message) {
        const auto kind = cli::imageMessageKind(message->getDataType());
        if (!kind) {
          if (!warned_type)
            cli::printWarning(
                fmt::format("topic {} carries {}, not sensor_msgs/Image or "
                            "CompressedImage: its messages are ignored",
                            image_topic, message->getDataType()));
          warned_type = true;
          return;
        }
        SerializedImage image;
        image.kind = *kind;
        image.bytes.resize(message->size());
        ros::serialization::OStream stream(image.bytes.data(), message->size());
        message->write(stream);
        source->mailbox().put(std::move(image));
      });

  std::mutex info_mutex;
  std::optional<sensor_msgs::CameraInfo> camera_info;
  ros::Subscriber info_sub;
  const bool use_camera_info = params.camera_info_wait > 0 && !params.intrinsics_given;
  if (use_camera_info)
    info_sub = nh.subscribe<sensor_msgs::CameraInfo>(
        "camera_info", 1, [&](const sensor_msgs::CameraInfo::ConstPtr& info) {
          std::lock_guard<std::mutex> lock(info_mutex);
          if (!camera_info) camera_info = *info;
        });

  QueryService queries(params.map_path);
  ros::ServiceServer query_server =
      private_nh.advertiseService("query", &QueryService::answer, &queries);
  ros::Publisher closures = private_nh.advertise<placedb_msgs::LoopClosure>("loop_closures", 100);
  ros::Publisher frames = private_nh.advertise<placedb_msgs::FrameStatus>("frames", 100);

  ros::AsyncSpinner spinner(2);  // images and camera_info beside a query in flight
  spinner.start();

  if (use_camera_info) {
    const auto deadline = std::chrono::steady_clock::now() +
                          std::chrono::duration_cast<std::chrono::steady_clock::duration>(
                              std::chrono::duration<double>(params.camera_info_wait));
    while (!stop() && std::chrono::steady_clock::now() < deadline) {
      {
        std::lock_guard<std::mutex> lock(info_mutex);
        if (camera_info) break;
      }
      std::this_thread::sleep_for(std::chrono::milliseconds(20));
    }
    std::lock_guard<std::mutex> lock(info_mutex);
    std::vector<std::string> intrinsics;
    if (camera_info) intrinsics = intrinsicsOf(*camera_info);
    if (intrinsics.empty() && !stop())
      cli::printWarning(fmt::format(
          "{} {} within {} s: a new session maps without intrinsics (no relative poses)",
          camera_info ? "the camera_info of" : "no camera_info for", image_topic,
          params.camera_info_wait));
    params.settings.assignments.insert(params.settings.assignments.begin(), intrinsics.begin(),
                                       intrinsics.end());
    info_sub.shutdown();
  }

  cli::MappingRequest request;
  request.map_path = params.map_path;
  request.source = params.source;
  request.opened_source = source;
  request.log_path = params.log_path;
  request.settings = params.settings;
  request.new_session = params.new_session;
  request.quiet = params.quiet;
  request.server_wait_s = params.server_wait;
  request.on_frame = [&](const cli::SourceFrame&, const FrameResult& result) {
    queries.frameCommitted();
    if (result.hypothesis.accepted) closures.publish(closureMessage(result, source->frameId()));
    frames.publish(statusMessage(result, source->frameId(), source->dropped()));
  };
  const cli::MappingSummary s = cli::runMapping(request);
  source->mailbox().close();
  if (!params.quiet)
    std::fputs(fmt::format("placedb: session {}: {} frames ({} bad) in {:.1f} s, {} new locations, "
                           "accepted loop closures {}, {} dropped while busy; the session is "
                           "closed and the next start resumes it\n",
                           s.session_id, s.processed, s.bad, s.seconds, s.locations_created,
                           s.loop_closures, s.dropped)
                   .c_str(),
               stderr);
  spinner.stop();
  return 0;
}

}  // namespace
}  // namespace placedb::ros_node

int main(int argc, char** argv) {
  using placedb::cli::printError;
  for (int i = 1; i < argc; ++i)
    if (!std::strcmp(argv[i], "--help") || !std::strcmp(argv[i], "-h")) {
      std::fputs(fmt::format(placedb::ros_node::kHelp, PLACEDB_VERSION_STRING,
                             placedb::cli::exitCodeTable())
                     .c_str(),
                 stdout);
      return 0;
    }
  std::signal(SIGXFSZ, SIG_IGN);  // a file-size limit is a full disk, as for `placedb map`
  // placedb's own handlers take SIGINT: the frame in flight finishes and the session closes.
  ros::init(argc, argv, "placedb", ros::init_options::NoSigintHandler);
  int status = 0;
  try {
    status = placedb::ros_node::run();
  } catch (const placedb::Error& e) {
    printError(e.what());
    status = placedb::cli::exitCodeFor(e.code());
  } catch (const std::exception& e) {
    printError(e.what());
    status = placedb::cli::exitCodeFor(placedb::ErrorCode::kInternal);
  }
  ros::shutdown();
  return status;
}
