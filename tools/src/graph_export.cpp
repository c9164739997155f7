#include "graph_export.h"

#include <fmt/format.h>

#include <algorithm>
#include <filesystem>
#include <fstream>
#include <map>
#include <tuple>

#include "placedb/error.h"
#include "placedb/storage/map_store.h"

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

// The one place that reads a closure's relative pose: the map stores none yet (the geometric
// check keeps only its inlier count), so every closure is appearance-only.
std::optional<RelativePose> storedPose(const storage::MapStore&, const storage::LinkRecord&) {
  return std::nullopt;
}

std::string framesText(const GraphLocation& location) {
  std::string text;
  for (const auto& f : location.frames)
    text += fmt::format("{}{}:{}", text.empty() ? "" : " ", f.session_id, f.source_index);
  return text;
}

std::string scoreText(const GraphLink& link) {
  return link.score ? fmt::format("{}", *link.score) : std::string();
}

std::ofstream openOutput(const std::filesystem::path& path) {
  std::ofstream out(path, std::ios::binary | std::ios::trunc);
  if (!out) throw Error(ErrorCode::kIo, fmt::format("cannot write {}", path.string()));
  return out;
}

void finish(std::ofstream& out, const std::filesystem::path& path) {
  out.flush();
  if (!out) throw Error(ErrorCode::kIo, fmt::format("cannot write {}", path.string()));
}

void writeCsv(const MapGraph& graph, const std::filesystem::path& folder) {
  std::error_code ec;
  std::filesystem::create_directories(folder, ec);
  if (ec)
    throw Error(ErrorCode::kIo, fmt::format("cannot create {}: {}", folder.string(), ec.message()));
  const auto locations_path = folder / "locations.csv";
  auto locations = openOutput(locations_path);
  locations << "location,session,tier,weight,frames\n";
  for (const auto& l : graph.locations)
    locations << fmt::format("{},{},{},{},{}\n", l.id, l.session_id, l.tier, l.weight,
                             framesText(l));
  finish(locations, locations_path);

  const auto links_path = folder / "links.csv";
  auto links = openOutput(links_path);
  links << "location_a,location_b,type,score,appearance_only,qx,qy,qz,qw,tx,ty,tz\n";
  for (const auto& k : graph.links) {
    std::string pose = ",,,,,,";
    if (k.pose) {
      const auto& q = k.pose->rotation_xyzw;
      const auto& t = k.pose->translation_direction;
      pose = fmt::format("{},{},{},{},{},{},{}", q[0], q[1], q[2], q[3], t[0], t[1], t[2]);
    }
    const bool closure = k.type == "loop_closure";
    links << fmt::format("{},{},{},{},{},{}\n", k.location_a, k.location_b, k.type, scoreText(k),
                         closure && !k.pose ? 1 : 0, pose);
  }
  finish(links, links_path);
}

void writeGraphml(const MapGraph& graph, const std::filesystem::path& path) {
  auto out = openOutput(path);
  out << "<?xml version=\"1.0\" encoding=\"UTF-8\"?>\n"
         "<graphml xmlns=\"http://graphml.graphdrawing.org/xmlns\">\n"
         "  <key id=\"session\" for=\"node\" attr.name=\"session\" attr.type=\"long\"/>\n"
         "  <key id=\"tier\" for=\"node\" attr.name=\"tier\" attr.type=\"string\"/>\n"
         "  <key id=\"weight\" for=\"node\" attr.name=\"weight\" attr.type=\"long\"/>\n"
         "  <key id=\"frames\" for=\"node\" attr.name=\"frames\" attr.type=\"string\"/>\n"
         "  <key id=\"type\" for=\"edge\" attr.name=\"type\" attr.type=\"string\"/>\n"
         "  <key id=\"score\" for=\"edge\" attr.name=\"score\" attr.type=\"double\"/>\n"
         "  <key id=\"appearance_only\" for=\"edge\" attr.name=\"appearance_only\" "
         "attr.type=\"boolean\"/>\n"
         "  <graph id=\"placedb\" edgedefault=\"undirected\">\n";
  for (const auto& l : graph.locations)
    out << fmt::format(
        "    <node id=\"n{}\"><data key=\"session\">{}</data><data key=\"tier\">{}</data>"
        "<data key=\"weight\">{}</data><data key=\"frames\">{}</data></node>\n",
        l.id, l.session_id, l.tier, l.weight, framesText(l));
  for (const auto& k : graph.links) {
    std::string data = fmt::format("<data key=\"type\">{}</data>", k.type);
    if (k.score) data += fmt::format("<data key=\"score\">{}</data>", *k.score);
    if (k.type == "loop_closure")
      data += fmt::format("<data key=\"appearance_only\">{}</data>", k.pose ? "false" : "true");
    out << fmt::format("    <edge source=\"n{}\" target=\"n{}\">{}</edge>\n", k.location_a,
                       k.location_b, data);
  }
  out << "  </graph>\n</graphml>\n";
  finish(out, path);
}

void writeG2o(const MapGraph& graph, const std::filesystem::path& path) {
  auto out = openOutput(path);
  out << "# placedb map graph: locations at the origin (no poses are stored); links in\n"
         "# odometry order, then loop closures. Replace the odometry edges with measured ones.\n";
  for (const auto& l : graph.locations)
    out << fmt::format("VERTEX_SE3:QUAT {} 0 0 0 0 0 0 1\n", l.id);
  // Unit information, upper triangle of the 6 x 6 matrix row by row.
  const std::string information = "1 0 0 0 0 0 1 0 0 0 0 1 0 0 0 1 0 0 1 0 1";
  for (const char* type : {"odometry", "loop_closure"}) {
    for (const auto& k : graph.links) {
      if (k.type != type) continue;
      RelativePose pose = k.pose.value_or(RelativePose{});
      if (k.type == "loop_closure" && !k.pose)
        out << fmt::format("# placedb appearance-only {} {} score {}\n", k.location_a, k.location_b,
                           scoreText(k));
      const auto& t = pose.translation_direction;
      const auto& q = pose.rotation_xyzw;
      out << fmt::format("EDGE_SE3:QUAT {} {} {} {} {} {} {} {} {} {}\n", k.location_a,
                         k.location_b, t[0], t[1], t[2], q[0], q[1], q[2], q[3], information);
    }
  }
  finish(out, path);
}

}  // namespace

MapGraph readMapGraph(const std::string& map_path) {
  if (!std::filesystem::exists(map_path))
    throw Error(ErrorCode::kIo, fmt::format("map {} does not exist", map_path));
  storage::MapStore store(map_path, storage::OpenMode::kReadOnly);

  std::map<std::int64_t, GraphFrame> frame_of;  // frame id -> session and source index
  for (const auto& s : store.sessions())
    for (const auto& f : store.frames(s.id)) frame_of[f.id] = {f.session_id, f.source_index};

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
                             storedPose(store, link)});
    }
  std::sort(graph.links.begin(), graph.links.end(), [](const GraphLink& a, const GraphLink& b) {
    return std::tie(a.location_a, a.location_b, a.type) <
           std::tie(b.location_a, b.location_b, b.type);
  });
  return graph;
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
