#include <fmt/format.h>

#include <cstdio>
#include <filesystem>
#include <nlohmann/json.hpp>

#include "commands/commands.h"
#include "commands/map_summary.h"
#include "exit_codes.h"
#include "frame_names.h"
#include "map_argument.h"
#include "placedb/map.h"
#include "placedb/storage/map_store.h"
#include "sources/image_source.h"

namespace placedb::cli {
namespace {

struct QueryRequest {
  std::string map_path;
  std::vector<std::string> images;
  std::size_t top = 5;
  bool json = false;
};

// The settings of the map's last session: localisation must extract features the same way.
Options storedOptions(const std::string& map_path) {
  requireExistingMap(map_path);
  auto options = lastSessionOptions(map_path);
  if (!options)
    throw Error(ErrorCode::kInvalidArgument,
                fmt::format("map {} has no session yet: map a sequence first", map_path));
  return *options;
}

nlohmann::json frameJson(const FrameRef& f) {
  return {{"session", f.session_id},
          {"frame_id", f.frame_id},
          {"source_index", f.source_index},
          {"stamp_ns", f.stamp_ns ? nlohmann::json(*f.stamp_ns) : nlohmann::json()},
          {"path", f.source_path}};
}

nlohmann::json framesJson(const std::vector<FrameRef>& frames) {
  nlohmann::json list = nlohmann::json::array();
  for (const auto& f : frames) list.push_back(frameJson(f));
  return list;
}

// A verified match's pose, under the names Python's QueryMatch.pose uses: the query's camera in
// that of the location's first frame (map.h), quaternion x, y, z, w as ROS and Eigen give it.
nlohmann::json poseJson(const QueryMatch& m) {
  if (!m.pose) return nullptr;
  nlohmann::json pose = {{"rotation_xyzw", {m.pose->qx, m.pose->qy, m.pose->qz, m.pose->qw}},
                         {"translation", {m.pose->tx, m.pose->ty, m.pose->tz}},
                         {"inliers", m.pose->inliers}};
  if (!m.frames.empty()) pose["relative_to"] = frameJson(m.frames.front());
  return pose;
}

// The lines under a match in the text output: its frames, then its pose or why it has none.
std::string matchDetails(const QueryMatch& m) {
  std::string text;
  for (const auto& f : m.frames)
    text += fmt::format("       frame {}  {}\n", frameName(f), f.source_path);
  if (m.pose && !m.frames.empty())
    text += fmt::format(
        "       pose relative to {}: rotation_xyzw ({:.4f}, {:.4f}, {:.4f}, {:.4f})  "
        "translation ({:.3f}, {:.3f}, {:.3f})  {} inliers\n",
        frameName(m.frames.front()), m.pose->qx, m.pose->qy, m.pose->qz, m.pose->qw, m.pose->tx,
        m.pose->ty, m.pose->tz, m.pose->inliers);
  else if (m.verified)
    text += fmt::format("       no pose: {}\n", m.no_pose_reason);
  return text;
}

// The images an argument names, as `placedb map` reads them: a folder's images in natural order,
// a list file's paths, or the image itself. A folder without images or an unreadable list is
// one error (an empty result).
std::vector<std::string> imagesOf(const std::string& argument, std::string& problem) {
  namespace fs = std::filesystem;
  std::error_code ec;
  if (fs::is_directory(argument, ec)) {
    std::vector<std::string> images, skipped;
    listImageFolder(argument, images, skipped);
    if (images.empty()) problem = "the folder holds no image";
    return images;
  }
  if (fs::is_regular_file(argument, ec) && !hasImageExtension(argument) &&
      !hasVideoExtension(argument)) {
    try {
      std::vector<std::string> paths = readListFile(argument);
      if (paths.empty()) problem = "the list file holds no image path";
      return paths;
    } catch (const Error&) {
      // Not a list after all (binary): read it as an image, which says what it is.
    }
  }
  return {argument};
}

int runQuery(const QueryRequest& request) {
  Options options = storedOptions(request.map_path);
  auto map = Map::open(request.map_path, options, Map::Mode::kLocalisation);
  nlohmann::json out = nlohmann::json::array();
  int status = 0;
  std::vector<std::string> images;
  for (const auto& argument : request.images) {
    std::string problem;
    const std::vector<std::string> named = imagesOf(argument, problem);
    if (!problem.empty()) {
      printError(fmt::format("cannot read images of {}: {}", argument, problem));
      status = exitCodeFor(ErrorCode::kIo);
      out.push_back({{"image", argument}, {"error", problem}});
    }
    images.insert(images.end(), named.begin(), named.end());
  }
  for (const auto& image_path : images) {
    std::string problem;
    cv::Mat image = readImageFile(image_path, problem);
    if (image.empty()) {
      printError(fmt::format("cannot read image {}: {}", image_path, problem));
      status = exitCodeFor(ErrorCode::kIo);
      out.push_back({{"image", image_path}, {"error", problem}});
      continue;
    }
    QueryResult result;
    try {
      result = map->query(image, request.top);
    } catch (const Error& e) {
      // An image the extractor cannot use (too small, too large) is this image's failure only;
      // anything else (the map, the disk) ends the command.
      if (e.code() != ErrorCode::kInvalidArgument) throw;
      printError(fmt::format("cannot use image {}: {}", image_path, e.what()));
      status = exitCodeFor(ErrorCode::kIo);
      out.push_back({{"image", image_path}, {"error", e.what()}});
      continue;
    }
    if (request.json) {
      nlohmann::json matches = nlohmann::json::array();
      for (const auto& m : result.matches) {
        nlohmann::json match = {
            {"location", m.location_id},     {"tier", storage::toString(m.tier)},
            {"similarity", m.similarity},    {"code_similarity", m.code_similarity},
            {"inliers", m.inliers},          {"verified", m.verified},
            {"frames", framesJson(m.frames)}};
        if (m.verified) {
          match["pose"] = poseJson(m);
          if (!m.pose) match["no_pose_reason"] = m.no_pose_reason;
        }
        matches.push_back(match);
      }
      out.push_back({{"image", image_path},
                     {"verdict", toString(result.verdict)},
                     {"feature_count", result.feature_count},
                     {"searched", result.searched},
                     {"checked", result.checked},
                     {"time_ms", result.time_ms},
                     {"matches", matches}});
      continue;
    }
    std::string text =
        fmt::format("{}: {} place; {} features, {} locations searched, {} checked, {:.1f} ms\n",
                    image_path, toString(result.verdict), result.feature_count, result.searched,
                    result.checked, result.time_ms);
    for (std::size_t i = 0; i < result.matches.size(); ++i) {
      const QueryMatch& m = result.matches[i];
      text += fmt::format(
          "  {}. location {} ({})  inliers {}{}  code similarity {:.3f}  similarity {:.4f}  "
          "({} frame{})\n",
          i + 1, m.location_id, storage::toString(m.tier), m.inliers, m.verified ? " verified" : "",
          m.code_similarity, m.similarity, m.frames.size(), m.frames.size() == 1 ? "" : "s");
      text += matchDetails(m);
    }
    std::fputs(text.c_str(), stdout);
  }
  if (request.json) std::fputs((out.dump(2) + "\n").c_str(), stdout);
  return status;
}

}  // namespace

Command addQueryCommand(CLI::App& parent) {
  auto request = std::make_shared<QueryRequest>();
  CLI::App* app =
      parent.add_subcommand("query", "Localise images against a map without changing it");
  app->footer(
      "Compare each IMAGE with every location stored in MAP, in every memory tier, and say\n"
      "whether it shows a known place (an IMAGE may be a folder or a list file: its images,\n"
      "read as `placedb map` reads them). Candidates are the locations most like the image by\n"
      "bag of words (short-term and working memory) and by place code (every tier, long-term\n"
      "memory included); each goes through the geometric check against its stored keypoints.\n"
      "Verdict: 'known' when the best candidate passes the check (geometry_rule),\n"
      "'unknown' when none does, 'unverified' when the map's settings switch the check off.\n"
      "Prints the best locations (verified first, by inliers), their tier, the frames they\n"
      "cover (SESSION:INDEX, @SECONDS when the source stamped them) and how many locations\n"
      "were searched. With camera intrinsics a verified match also gets its pose: the query's\n"
      "camera in that of the location's first frame (--json: pose.rotation_xyzw, translation,\n"
      "inliers, relative_to); without one a verified match says why (no_pose_reason). The map\n"
      "is opened read-only with the settings of its last session.\n"
      "Exit status 3 when an image cannot be read or used (a folder, not an image, too small\n"
      "or too large): it gets one error line naming it, and the others are still answered.\n\n"
      "Examples:\n"
      "  placedb query run.placedb photo.jpg\n"
      "  placedb query run.placedb a.png b.png --top 3 --json\n"
      "  placedb query run.placedb second_run/frames.txt --json");
  app->add_option("MAP", request->map_path, "map: a file or a postgresql:// URI")
      ->required()
      ->transform(mapArgument());
  app->add_option("IMAGE", request->images, "images to localise (or folders, list files)")
      ->required();
  app->add_option("--top,-k", request->top, "locations to print per image")
      ->check(CLI::PositiveNumber);
  app->add_flag("--json", request->json, "print one JSON array");
  return {app, [request]() { return runQuery(*request); }};
}

}  // namespace placedb::cli
