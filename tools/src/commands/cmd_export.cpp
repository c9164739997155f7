#include <fmt/format.h>

#include <algorithm>
#include <cctype>
#include <cstdio>
#include <filesystem>
#include <memory>
#include <optional>

#include "commands/commands.h"
#include "frame_names.h"
#include "map_argument.h"
#include "output_guard.h"
#include "placedb/error.h"
#include "report/graph_export.h"

namespace placedb::cli {
namespace {

// The format an output's extension names (any case); a folder or another extension has to say.
std::string formatOfExtension(const std::string& out) {
  std::string ext = std::filesystem::path(out).extension().string();
  std::transform(ext.begin(), ext.end(), ext.begin(),
                 [](unsigned char c) { return static_cast<char>(std::tolower(c)); });
  if (ext == ".g2o") return "g2o";
  if (ext == ".graphml") return "graphml";
  throw Error(ErrorCode::kInvalidArgument,
              fmt::format("export: cannot tell the format of {} from its name: give --format g2o, "
                          "graphml or csv",
                          out));
}

}  // namespace

Command addExportCommand(CLI::App& parent) {
  struct Request {
    std::string map_path, out, format, poses;
  };
  auto request = std::make_shared<Request>();
  CLI::App* app =
      parent.add_subcommand("export", "Write a map's locations and links for graph tools");
  app->footer(
      "Write every location (session, tier, weight, the frames it covers as SESSION:INDEX),\n"
      "the odometry-order links between consecutive locations and the loop-closure links\n"
      "(score; relative pose where the map stores one, otherwise flagged appearance-only).\n"
      "The map is opened read-only. Frames are named SESSION:INDEX, with @SECONDS when the\n"
      "source stamped them (stamps_ns in ns in the CSV and GraphML).\n\n"
      "  csv      OUT is a folder: locations.csv and links.csv\n"
      "  graphml  one GraphML file (Gephi, yEd, networkx)\n"
      "  g2o      one g2o file: VERTEX_SE3:QUAT per location, after a comment naming its\n"
      "           frames, EDGE_SE3:QUAT per odometry link and loop closure; an appearance-only\n"
      "           closure is the identity, after a `# placedb appearance-only A B` comment\n\n"
      "placedb keeps no metric poses: without --poses every vertex is at the origin and every\n"
      "odometry edge the identity. --poses FILE (a CSV `stamp_ns,x,y,z,qx,qy,qz,qw`: the\n"
      "camera's pose at each stamp, e.g. odometry; `rostopic echo -p` of a nav_msgs/Odometry\n"
      "topic reads as it is) places each location at its first frame's stamp (interpolated\n"
      "between the poses around it) and measures the odometry edges between placed ones; the\n"
      "frames need stamps (a ROS bag's, or stamp_ns given to Python's Map.process).\n\n"
      "Examples:\n"
      "  placedb export run.placedb graph.g2o              (the format from the extension)\n"
      "  placedb export run.placedb graph.g2o --poses odometry.csv\n"
      "  placedb export run.placedb graph.graphml --format graphml\n"
      "  placedb export run.placedb graph/ --format csv");
  app->add_option("MAP", request->map_path, "map: a file or a postgresql:// URI")
      ->required()
      ->transform(mapArgument());
  app->add_option("OUT", request->out, "file to write (a folder for csv)")->required();
  app->add_option("--format", request->format,
                  "g2o, graphml or csv; by default the extension of OUT (.g2o, .graphml)")
      ->check(CLI::IsMember({"g2o", "graphml", "csv"}));
  app->add_option("--poses", request->poses,
                  "a CSV of stamped poses (stamp_ns,x,y,z,qx,qy,qz,qw): the locations' vertices "
                  "and the odometry edges from it")
      ->type_name("FILE");
  return {
      app, [request]() {
        if (request->format.empty()) request->format = formatOfExtension(request->out);
        refuseMapAsOutput("export", request->map_path, request->out);
        std::optional<PoseTrack> track;
        if (!request->poses.empty()) track = readPoseCsv(request->poses);
        MapGraph graph = readMapGraph(request->map_path);
        std::string placed;
        if (track) {
          const std::size_t n = attachPoses(graph, *track);
          if (n == 0)
            throw Error(ErrorCode::kInvalidArgument,
                        fmt::format("poses {}: no location of {} has a first frame stamped "
                                    "within its stamps ({} to {}); nothing written",
                                    request->poses, request->map_path,
                                    stampText(track->firstStamp()), stampText(track->lastStamp())));
          placed = fmt::format(", {} of them placed from {}", n, request->poses);
        }
        writeMapGraph(graph, request->format, request->out);
        std::size_t closures = 0;
        for (const auto& link : graph.links) closures += link.type == "loop_closure";
        std::fputs(
            fmt::format("placedb: wrote {} locations{}, {} links ({} loop closures) "
                        "to {}\n",
                        graph.locations.size(), placed, graph.links.size(), closures, request->out)
                .c_str(),
            stderr);
        return 0;
      }};
}

}  // namespace placedb::cli
