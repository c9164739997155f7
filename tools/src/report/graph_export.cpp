#include "report/graph_export.h"
#include "map_argument.h"

#include <fmt/format.h>

#include <algorithm>
#include <filesystem>
#include <map>
#include <tuple>

#include "frame_names.h"
#include "placedb/error.h"
#include "placedb/storage/map_store.h"
#include "whole_file.h"

namespace placedb::cli {
namespace {

const char* linkTypeName(storage::LinkType type) {
  switch (type) {
    case storage::LinkType::kNeighbour:
      return "odometry";
    case storage::LinkType::kLoopClosure:
      return "loop_closure";
    case storage::LinkType::kMerge:
      return "merge";
  }
  return "?";
}

using PoseOfPair = std::map<std::pair<std::int64_t, std::int64_t>, storage::ClosurePoseRecord>;

// The closure poses the map stores, one per location pair (a < b): the frame whose essential
// matrix had the most inliers, the latest on a tie. A pair closed again and again gets many.
PoseOfPair storedPoses(const storage::MapStore& store) {
  PoseOfPair best;
  for (const auto& record : store.closurePoses()) {
    const auto key = std::minmax(record.frame_location_id, record.hypothesis_location_id);
    auto [it, inserted] = best.emplace(key, record);
    if (!inserted && record.pose.inliers >= it->second.pose.inliers) it->second = record;
  }
  return best;
}

// The one place that reads a closure's relative pose. The map stores the frame's camera in the
// hypothesis location's (hypotheses.pose_*); an edge a -> b wants b's in a's, so a pose stored
// from the other side is inverted: (R, t) -> (R', -R' t).
std::optional<RelativePose> storedPose(const PoseOfPair& poses, const storage::LinkRecord& link) {
  if (link.type != storage::LinkType::kLoopClosure) return std::nullopt;
  const auto found = poses.find({link.location_a, link.location_b});
  if (found == poses.end()) return std::nullopt;
  const storage::ClosurePose& p = found->second.pose;
  RelativePose pose;
  pose.inliers = p.inliers;
  if (found->second.frame_location_id == link.location_b) {
    pose.rotation_xyzw = {p.qx, p.qy, p.qz, p.qw};
    pose.translation_direction = {p.tx, p.ty, p.tz};
    return pose;
  }
  // The conjugate quaternion is R'; rotate t by it and negate.
  const double w = p.qw, x = -p.qx, y = -p.qy, z = -p.qz;
  const double r[3][3] = {{1 - 2 * (y * y + z * z), 2 * (x * y - w * z), 2 * (x * z + w * y)},
                          {2 * (x * y + w * z), 1 - 2 * (x * x + z * z), 2 * (y * z - w * x)},
                          {2 * (x * z - w * y), 2 * (y * z + w * x), 1 - 2 * (x * x + y * y)}};
  const double t[3] = {p.tx, p.ty, p.tz};
  for (int i = 0; i < 3; ++i)
    pose.translation_direction[static_cast<std::size_t>(i)] =
        -(r[i][0] * t[0] + r[i][1] * t[1] + r[i][2] * t[2]);
  pose.rotation_xyzw = {x, y, z, w};
  return pose;
}

std::string framesText(const GraphLocation& location) {
  std::string text;
  for (const auto& f : location.frames)
    text += fmt::format("{}{}:{}", text.empty() ? "" : " ", f.session_id, f.source_index);
  return text;
}

// The frames' stamps in the order of framesText ("-" for a frame without one); empty when no
// frame of the location has a stamp.
std::string stampsText(const GraphLocation& location) {
  std::string text;
  bool any = false;
  for (const auto& f : location.frames) {
    any = any || f.stamp_ns.has_value();
    text += (text.empty() ? "" : " ") + (f.stamp_ns ? std::to_string(*f.stamp_ns) : "-");
  }
  return any ? text : std::string();
}

// "x,y,z,qx,qy,qz,qw" of a placed location; empty fields otherwise.
std::string poseFields(const std::optional<Pose3>& pose) {
  if (!pose) return ",,,,,,";
  const auto& p = pose->position;
  const auto& q = pose->rotation_xyzw;
  return fmt::format("{},{},{},{},{},{},{}", p[0], p[1], p[2], q[0], q[1], q[2], q[3]);
}

// Every frame of a location as frame_names.h names it, for the g2o comments.
std::string frameNamesText(const GraphLocation& location) {
  std::string text;
  for (const auto& f : location.frames)
    text += (text.empty() ? "" : " ") + frameName(f.session_id, f.source_index, f.stamp_ns);
  return text;
}

std::string scoreText(const GraphLink& link) {
  return link.score ? fmt::format("{}", *link.score) : std::string();
}

void writeCsv(const MapGraph& graph, const std::filesystem::path& folder) {
  std::error_code ec;
  std::filesystem::create_directories(folder, ec);
  if (ec)
    throw Error(ErrorCode::kIo, fmt::format("cannot create {}: {}", folder.string(), ec.message()));
  const auto locations_path = folder / "locations.csv";
  std::string locations;
  locations += "location,session,tier,weight,frames,stamps_ns,x,y,z,qx,qy,qz,qw\n";
  for (const auto& l : graph.locations)
    locations += fmt::format("{},{},{},{},{},{},{}\n", l.id, l.session_id, l.tier, l.weight,
                             framesText(l), stampsText(l), poseFields(l.pose));
  writeWholeFile(locations_path, locations);

  const auto links_path = folder / "links.csv";
  std::string links;
  links += "location_a,location_b,type,score,appearance_only,qx,qy,qz,qw,tx,ty,tz,pose_inliers\n";
  for (const auto& k : graph.links) {
    std::string pose = ",,,,,,,";
    if (k.pose) {
      const auto& q = k.pose->rotation_xyzw;
      const auto& t = k.pose->translation_direction;
      pose = fmt::format("{},{},{},{},{},{},{},{}", q[0], q[1], q[2], q[3], t[0], t[1], t[2],
                         k.pose->inliers);
    } else if (k.odometry) {
      const auto& q = k.odometry->rotation_xyzw;
      const auto& t = k.odometry->position;
      pose = fmt::format("{},{},{},{},{},{},{},", q[0], q[1], q[2], q[3], t[0], t[1], t[2]);
    }
    const bool closure = k.type == "loop_closure";
    links += fmt::format("{},{},{},{},{},{}\n", k.location_a, k.location_b, k.type, scoreText(k),
                         closure && !k.pose ? 1 : 0, pose);
  }
  writeWholeFile(links_path, links);
}

void writeGraphml(const MapGraph& graph, const std::filesystem::path& path) {
  std::string out;
  out +=
      "<?xml version=\"1.0\" encoding=\"UTF-8\"?>\n"
      "<graphml xmlns=\"http://graphml.graphdrawing.org/xmlns\">\n"
      "  <key id=\"session\" for=\"node\" attr.name=\"session\" attr.type=\"long\"/>\n"
      "  <key id=\"tier\" for=\"node\" attr.name=\"tier\" attr.type=\"string\"/>\n"
      "  <key id=\"weight\" for=\"node\" attr.name=\"weight\" attr.type=\"long\"/>\n"
      "  <key id=\"frames\" for=\"node\" attr.name=\"frames\" attr.type=\"string\"/>\n"
      "  <key id=\"stamps_ns\" for=\"node\" attr.name=\"stamps_ns\" attr.type=\"string\"/>\n"
      "  <key id=\"type\" for=\"edge\" attr.name=\"type\" attr.type=\"string\"/>\n"
      "  <key id=\"score\" for=\"edge\" attr.name=\"score\" attr.type=\"double\"/>\n"
      "  <key id=\"appearance_only\" for=\"edge\" attr.name=\"appearance_only\" "
      "attr.type=\"boolean\"/>\n";
  for (const char* key : {"qx", "qy", "qz", "qw", "tx", "ty", "tz"})
    out += fmt::format("  <key id=\"{0}\" for=\"edge\" attr.name=\"{0}\" attr.type=\"double\"/>\n",
                       key);
  // A placed node's pose (attachPoses) under the names of locations.csv; key ids differ from the
  // edges' qx ... qw, which GraphML wants unique.
  for (const char* key : {"x", "y", "z", "qx", "qy", "qz", "qw"})
    out += fmt::format(
        "  <key id=\"node_{0}\" for=\"node\" attr.name=\"{0}\" attr.type=\"double\"/>\n", key);
  out +=
      "  <key id=\"pose_inliers\" for=\"edge\" attr.name=\"pose_inliers\" "
      "attr.type=\"long\"/>\n"
      "  <graph id=\"placedb\" edgedefault=\"directed\">\n";
  for (const auto& l : graph.locations) {
    const std::string stamps = stampsText(l);
    std::string pose;
    if (l.pose) {
      const auto& p = l.pose->position;
      const auto& q = l.pose->rotation_xyzw;
      const double values[] = {p[0], p[1], p[2], q[0], q[1], q[2], q[3]};
      const char* keys[] = {"x", "y", "z", "qx", "qy", "qz", "qw"};
      for (int i = 0; i < 7; ++i)
        pose += fmt::format("<data key=\"node_{}\">{}</data>", keys[i], values[i]);
    }
    out += fmt::format(
        "    <node id=\"{}\"><data key=\"session\">{}</data><data key=\"tier\">{}</data>"
        "<data key=\"weight\">{}</data><data key=\"frames\">{}</data>{}{}</node>\n",
        l.id, l.session_id, l.tier, l.weight, framesText(l),
        stamps.empty() ? "" : fmt::format("<data key=\"stamps_ns\">{}</data>", stamps), pose);
  }
  for (const auto& k : graph.links) {
    std::string data = fmt::format("<data key=\"type\">{}</data>", k.type);
    if (k.score) data += fmt::format("<data key=\"score\">{}</data>", *k.score);
    if (k.type == "loop_closure")
      data += fmt::format("<data key=\"appearance_only\">{}</data>", k.pose ? "false" : "true");
    if (k.pose || k.odometry) {
      const auto& q = k.pose ? k.pose->rotation_xyzw : k.odometry->rotation_xyzw;
      const auto& t = k.pose ? k.pose->translation_direction : k.odometry->position;
      const double values[] = {q[0], q[1], q[2], q[3], t[0], t[1], t[2]};
      const char* keys[] = {"qx", "qy", "qz", "qw", "tx", "ty", "tz"};
      for (int i = 0; i < 7; ++i)
        data += fmt::format("<data key=\"{}\">{}</data>", keys[i], values[i]);
    }
    if (k.pose) data += fmt::format("<data key=\"pose_inliers\">{}</data>", k.pose->inliers);
    out += fmt::format("    <edge source=\"{}\" target=\"{}\">{}</edge>\n", k.location_a,
                       k.location_b, data);
  }
  out += "  </graph>\n</graphml>\n";
  writeWholeFile(path, out);
}

void writeG2o(const MapGraph& graph, const std::filesystem::path& path) {
  std::size_t placed = 0;
  for (const auto& l : graph.locations) placed += l.pose.has_value();
  std::string out;
  out += placed == 0
             ? "# placedb map graph: locations at the origin (no poses were given: placedb export\n"
               "# --poses FILE places them); links in odometry order, then loop closures.\n"
             : fmt::format(
                   "# placedb map graph: {} of {} locations at their poses from a pose "
                   "track,\n# the others at the origin; links in odometry order, then "
                   "loop closures.\n",
                   placed, graph.locations.size());
  out += "# A closure with a pose: unit translation direction, zero translation information.\n";
  for (const auto& l : graph.locations) {
    out += fmt::format("# placedb location {} frames {}\n", l.id, frameNamesText(l));
    const Pose3 pose = l.pose.value_or(Pose3{});
    const auto& p = pose.position;
    const auto& q = pose.rotation_xyzw;
    out += fmt::format("VERTEX_SE3:QUAT {} {} {} {} {} {} {} {}\n", l.id, p[0], p[1], p[2], q[0],
                       q[1], q[2], q[3]);
  }
  // Upper triangle of the 6 x 6 information matrix row by row (x y z, then rotation): unit,
  // or for a measured closure zero on the translation, whose scale one camera cannot measure.
  const std::string information = "1 0 0 0 0 0 1 0 0 0 0 1 0 0 0 1 0 0 1 0 1";
  const std::string rotation_only = "0 0 0 0 0 0 0 0 0 0 0 0 0 0 0 1 0 0 1 0 1";
  for (const char* type : {"odometry", "loop_closure"}) {
    for (const auto& k : graph.links) {
      if (k.type != type) continue;
      std::array<double, 3> t{0, 0, 0};
      std::array<double, 4> q{0, 0, 0, 1};
      if (k.pose) {
        t = k.pose->translation_direction;
        q = k.pose->rotation_xyzw;
      } else if (k.odometry) {
        t = k.odometry->position;
        q = k.odometry->rotation_xyzw;
      }
      if (k.type == "loop_closure" && !k.pose)
        out += fmt::format("# placedb appearance-only {} {} score {}\n", k.location_a, k.location_b,
                           scoreText(k));
      if (k.pose)
        out += fmt::format("# placedb pose {} {} inliers {} score {}\n", k.location_a, k.location_b,
                           k.pose->inliers, scoreText(k));
      out += fmt::format("EDGE_SE3:QUAT {} {} {} {} {} {} {} {} {} {}\n", k.location_a,
                         k.location_b, t[0], t[1], t[2], q[0], q[1], q[2], q[3],
                         k.pose ? rotation_only : information);
    }
  }
  writeWholeFile(path, out);
}

}  // namespace

MapGraph readMapGraph(const std::string& map_path) {
  requireExistingMap(map_path);
  const auto store_owner = storage::openMapStore(map_path, storage::OpenMode::kReadOnly);
  storage::MapStore& store = *store_owner;

  std::map<std::int64_t, GraphFrame> frame_of;  // frame id -> session and source index
  for (const auto& s : store.sessions())
    for (const auto& f : store.frames(s.id))
      frame_of[f.id] = {f.session_id, f.source_index, f.stamp_ns};

  const PoseOfPair poses = storedPoses(store);
  MapGraph graph;
  for (auto tier : {storage::Tier::kStm, storage::Tier::kWm, storage::Tier::kLtm})
    for (const auto& l : store.locationsInTier(tier)) {
      GraphLocation location;
      location.id = l.id;
      location.weight = l.weight;
      location.tier = storage::toString(tier);
      if (auto record = store.location(l.id)) location.session_id = record->session_id;
      graph.locations.push_back(location);
    }
  std::sort(graph.locations.begin(), graph.locations.end(),
            [](const GraphLocation& a, const GraphLocation& b) { return a.id < b.id; });
  std::vector<std::int64_t> ids;
  for (const auto& l : graph.locations) ids.push_back(l.id);
  const auto covered = store.coveredFrames(ids);
  for (auto& l : graph.locations) {
    auto frames = covered.find(l.id);
    if (frames == covered.end()) continue;
    std::vector<std::int64_t> frame_ids = frames->second;
    std::sort(frame_ids.begin(), frame_ids.end());
    for (std::int64_t id : frame_ids)
      if (auto f = frame_of.find(id); f != frame_of.end()) l.frames.push_back(f->second);
  }

  for (const auto& l : graph.locations)
    for (const auto& link : store.links(l.id)) {
      if (link.location_a != l.id) continue;  // each stored link once
      graph.links.push_back({link.location_a, link.location_b, linkTypeName(link.type), link.score,
                             storedPose(poses, link), std::nullopt});
    }
  std::sort(graph.links.begin(), graph.links.end(), [](const GraphLink& a, const GraphLink& b) {
    return std::tie(a.location_a, a.location_b, a.type) <
           std::tie(b.location_a, b.location_b, b.type);
  });
  return graph;
}

std::size_t attachPoses(MapGraph& graph, const PoseTrack& track) {
  std::map<std::int64_t, const GraphLocation*> by_id;
  std::size_t placed = 0;
  for (auto& l : graph.locations) {
    l.pose.reset();
    if (!l.frames.empty() && l.frames.front().stamp_ns)
      l.pose = track.at(*l.frames.front().stamp_ns);
    placed += l.pose.has_value();
    by_id[l.id] = &l;
  }
  for (auto& k : graph.links) {
    k.odometry.reset();
    if (k.type != "odometry") continue;
    const auto a = by_id.find(k.location_a), b = by_id.find(k.location_b);
    if (a == by_id.end() || b == by_id.end() || !a->second->pose || !b->second->pose) continue;
    k.odometry = between(*a->second->pose, *b->second->pose);
  }
  return placed;
}

void writeMapGraph(const MapGraph& graph, const std::string& format,
                   const std::filesystem::path& out) {
  if (format == "csv")
    writeCsv(graph, out);
  else if (format == "graphml")
    writeGraphml(graph, out);
  else if (format == "g2o")
    writeG2o(graph, out);
  else
    throw Error(ErrorCode::kInvalidArgument,
                fmt::format("export format {} is not valid (valid: g2o|graphml|csv)", format));
}

}  // namespace placedb::cli
