#include <fmt/format.h>

#include <algorithm>
#include <cctype>
#include <cstdio>
#include <filesystem>
#include <memory>

#include "commands.h"
#include "graph_export.h"
#include "map_argument.h"
#include "output_guard.h"
#include "placedb/error.h"

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
    std::string map_path, out, format;
  };
  auto request = std::make_shared<Request>();
  CLI::App* app =
      parent.add_subcommand("export", "Write a map's locations and links for graph tools");
  app->footer(
      "Write every location (session, tier, weight, the frames it covers as SESSION:INDEX),\n"
      "the odometry-order links between consecutive locations and the loop-closure links\n"
      "(score; relative pose where the map stores one, otherwise flagged appearance-only).\n"
      "The map is opened read-only.\n\n"
      "  csv      OUT is a folder: locations.csv and links.csv\n"
      "  graphml  one GraphML file (Gephi, yEd, networkx)\n"
      "  g2o      one g2o file: VERTEX_SE3:QUAT per location at the origin (placedb keeps no\n"
      "           poses), EDGE_SE3:QUAT per odometry link and loop closure; an appearance-only\n"
      "           closure is the identity, after a `# placedb appearance-only A B` comment\n\n"
      "Examples:\n"
      "  placedb export run.placedb graph.g2o              (the format from the extension)\n"
      "  placedb export run.placedb graph.graphml --format graphml\n"
      "  placedb export run.placedb graph/ --format csv");
  app->add_option("MAP", request->map_path, "map: a file or a postgresql:// URI")
      ->required()
      ->transform(mapArgument());
  app->add_option("OUT", request->out, "file to write (a folder for csv)")->required();
  app->add_option("--format", request->format,
                  "g2o, graphml or csv; by default the extension of OUT (.g2o, .graphml)")
      ->check(CLI::IsMember({"g2o", "graphml", "csv"}));
  return {app, [request]() {
            if (request->format.empty()) request->format = formatOfExtension(request->out);
            refuseMapAsOutput("export", request->map_path, request->out);
            const MapGraph graph = readMapGraph(request->map_path);
            writeMapGraph(graph, request->format, request->out);
            std::size_t closures = 0;
            for (const auto& link : graph.links) closures += link.type == "loop_closure";
            std::fputs(
                fmt::format("placedb: wrote {} locations, {} links ({} loop closures) to {}\n",
                            graph.locations.size(), graph.links.size(), closures, request->out)
                    .c_str(),
                stderr);
            return 0;
          }};
}

}  // namespace placedb::cli
