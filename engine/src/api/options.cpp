// The settings catalogue: one row per key, shared by parsing, printing, validation and --help.
#include "placedb/options.h"

#include <fmt/format.h>

#include <array>
#include <cerrno>
#include <cmath>
#include <cstdlib>
#include <functional>
#include <limits>

#include "api/setting_aliases.h"
#include "placedb/error.h"

namespace placedb {
namespace {

template <typename Enum, std::size_t N>
Enum parseName(const std::array<const char*, N>& names, const std::string& text,
               const std::string& key) {
  std::string valid;
  for (std::size_t i = 0; i < N; ++i) {
    if (text == names[i]) return static_cast<Enum>(i);
    valid += (i ? "|" : "") + std::string(names[i]);
  }
  throw Error(ErrorCode::kInvalidArgument,
              fmt::format("setting {}={} is out of range: valid values are {}", key, text, valid));
}

constexpr const char* kNotAChoice = "invalid";

template <typename Enum, std::size_t N>
const char* nameOf(const std::array<const char*, N>& names, Enum value) {
  const auto i = static_cast<std::size_t>(value);
  return i < N ? names[i] : kNotAChoice;
}

// Indexed by the enum's value.
constexpr std::array<const char*, 3> kExtractorNames = {"surf", "sift", "kaze"};
constexpr std::array<const char*, 2> kWordRuleNames = {"greedy", "nndr"};
constexpr std::array<const char*, 2> kDistanceUnitNames = {"squared", "euclidean"};
constexpr std::array<const char*, 2> kDecisionRuleNames = {"rtabmap", "paper"};
constexpr std::array<const char*, 3> kGeometryRuleNames = {"inliers", "nfa", "either"};

struct Row {
  const char* key;
  const char* valid;
  const char* description;
  double min = 1, max = 0;  // numeric rows: the closed range `ok` checks
  std::function<std::string(const Options&)> get;
  std::function<void(Options&, const std::string&)> set;  // throws with the reason
  std::function<bool(const Options&)> ok;                 // range check on the typed value
};

[[noreturn]] void refuse(const std::string& key, const std::string& value, const char* valid) {
  throw Error(ErrorCode::kInvalidArgument,
              fmt::format("setting {}={} is out of range: valid values are {}", key, value, valid));
}

double parseDouble(const std::string& key, const std::string& text, const char* valid) {
  errno = 0;
  char* end = nullptr;
  double v = std::strtod(text.c_str(), &end);
  if (text.empty() || end != text.c_str() + text.size() || errno != 0 || v != v)
    throw Error(ErrorCode::kInvalidArgument,
                fmt::format("setting {}={} is not a number (valid: {})", key, text, valid));
  return v;
}

int parseInt(const std::string& key, const std::string& text, const char* valid) {
  errno = 0;
  char* end = nullptr;
  long v = std::strtol(text.c_str(), &end, 10);
  if (text.empty() || end != text.c_str() + text.size() || errno != 0 ||
      v < std::numeric_limits<int>::min() || v > std::numeric_limits<int>::max())
    throw Error(ErrorCode::kInvalidArgument,
                fmt::format("setting {}={} is not an integer (valid: {})", key, text, valid));
  return static_cast<int>(v);
}

bool parseBool(const std::string& key, const std::string& text) {
  if (text == "true" || text == "1" || text == "yes" || text == "on") return true;
  if (text == "false" || text == "0" || text == "no" || text == "off") return false;
  throw Error(ErrorCode::kInvalidArgument,
              fmt::format("setting {}={} is not a boolean (valid: true|false)", key, text));
}

std::string formatDouble(double v) { return fmt::format("{}", v); }

// Row builders keep the table below one line of intent per setting.
Row real(const char* key, double Options::*m, double lo, double hi, const char* valid,
         const char* description) {
  return {key,
          valid,
          description,
          lo,
          hi,
          [m](const Options& o) { return formatDouble(o.*m); },
          [m, key, valid](Options& o, const std::string& t) { o.*m = parseDouble(key, t, valid); },
          [m, lo, hi](const Options& o) { return o.*m >= lo && o.*m <= hi; }};
}

Row integer(const char* key, int Options::*m, int lo, int hi, const char* valid,
            const char* description) {
  return {key,
          valid,
          description,
          static_cast<double>(lo),
          static_cast<double>(hi),
          [m](const Options& o) { return std::to_string(o.*m); },
          [m, key, valid](Options& o, const std::string& t) { o.*m = parseInt(key, t, valid); },
          [m, lo, hi](const Options& o) { return o.*m >= lo && o.*m <= hi; }};
}

Row boolean(const char* key, bool Options::*m, const char* description) {
  return {key,
          "true|false",
          description,
          1,
          0,
          [m](const Options& o) { return std::string(o.*m ? "true" : "false"); },
          [m, key](Options& o, const std::string& t) { o.*m = parseBool(key, t); },
          [](const Options&) { return true; }};
}

// A choice's text is parsed strictly by `parse`; `ok` only catches a value cast from a number.
template <typename Enum>
Row choice(const char* key, Enum Options::*m, Enum (*parse)(const std::string&, const std::string&),
           const char* valid, const char* description) {
  return {key,
          valid,
          description,
          1,
          0,
          [m](const Options& o) { return std::string(toString(o.*m)); },
          [m, parse, key](Options& o, const std::string& t) { o.*m = parse(t, key); },
          [m](const Options& o) { return toString(o.*m) != std::string(kNotAChoice); }};
}

const std::vector<Row>& table() {
  // Ranges are those the components accept (options_test holds them to it); an open end is
  // written as the nearest value inside.
  const double kBelowOne = std::nextafter(1.0, 0.0);
  static const std::vector<Row> rows = {
      choice("extractor", &Options::extractor, parseExtractor, "surf|sift|kaze",
             "feature extractor; a map keeps the one it was made with"),
      real("hessian_threshold", &Options::hessian_threshold, 0, 1e12, "0..1e12",
           "SURF fast-Hessian threshold: lower finds more, weaker features"),
      integer("octaves", &Options::octaves, 1, 8, "1..8", "SURF octaves"),
      integer("intervals", &Options::intervals, 1, 8, "1..8", "SURF intervals per octave"),
      boolean("upright", &Options::upright, "U-SURF: skip orientation (camera never rolls)"),
      integer("max_features", &Options::max_features, 0, 100000, "0..100000",
              "strongest features kept per image, 0 = all"),
      integer("feature_target", &Options::feature_target, 0, 100000, "0..100000",
              "SURF: an image with at most feature_retry x this many features is searched again "
              "at twice its size, keeping at most this many; 0 = off"),
      real("feature_retry", &Options::feature_retry, 0, 1, "0..1",
           "share of feature_target at or under which an image is searched again at twice its "
           "size (the finer features replace its own when 1/feature_retry times as many); 0 = "
           "off"),
      real("min_response", &Options::min_response, 0, 1e30, "0..1e30",
           "features with a weaker detector response are dropped"),
      real("bad_ratio", &Options::bad_ratio, 0, 1, "0..1",
           "an image with fewer features than this x the running mean is bad (never a location)"),
      choice("word_rule", &Options::word_rule, parseWordRule, "greedy|nndr",
             "word creation rule: greedy (paper 000, algorithm 3) or NNDR (algorithms 1-2)"),
      choice("distance_unit", &Options::distance_unit, parseDistanceUnit, "squared|euclidean",
             "unit of t_nd1, t_nd2 and the ratio test (RTAB-Map's is squared)"),
      real("t_nndr", &Options::t_nndr, 0, 1, "0..1", "nearest/second-nearest ratio threshold"),
      real("t_nd1", &Options::t_nd1, 0, 1e30, "0..1e30",
           "greedy: below this ND a feature takes its word"),
      real("t_nd2", &Options::t_nd2, 0, 1e30, "0..1e30",
           "greedy: above this ND a feature makes a word"),
      integer("kd_trees", &Options::kd_trees, 1, 64, "1..64",
              "randomized kd-trees of the word index"),
      integer("kd_checks", &Options::kd_checks, 1, 1 << 20, "1..1048576",
              "kd-tree leaves checked per query (recall vs time)"),
      integer("threads", &Options::threads, 0, 64, "0..64",
              "worker threads of feature extraction, quantisation, the place-code scan and the "
              "candidates' checks, 0 = one per hardware thread; decisions never depend on it"),
      integer("stm_size", &Options::stm_size, 1, 10000, "1..10000",
              "short-term memory: newest locations, never loop candidates"),
      real("t_sim", &Options::t_sim, 0, 1, "0..1",
           "merge a new location into the previous one above this similarity"),
      integer("wm_max", &Options::wm_max, 0, 100000000, "0..1e8",
              "working-memory size that triggers transfer to LTM, 0 = unbounded"),
      real("t_time_ms", &Options::t_time_ms, 0, 1e9, "0..1e9",
           "time budget in ms of the stages that grow with memory (LTM search, likelihood, "
           "filter update, retrieval; not features nor verification): above it WM locations "
           "move to LTM, 0 = off"),
      integer("wm_min", &Options::wm_min, 0, 100000000, "0..1e8",
              "the time budget never shrinks working memory below this many locations"),
      integer("max_retrieved", &Options::max_retrieved, 0, 1000, "0..1000",
              "LTM neighbours of the best hypothesis brought back per frame"),
      integer("ltm_search", &Options::ltm_search, 0, 1000, "0..1000",
              "places most like the frame by place code, WM and LTM; those in LTM are brought "
              "back before the filter runs, 0 = off"),
      integer("read_ahead_links", &Options::read_ahead_links, 0, 100, "0..100",
              "reading ahead: the places the next frame may bring back from LTM (this frame's "
              "hypothesis and its place-code search, ranked 3 x ltm_search deep) and those this "
              "many links from them are read on a thread of their own, so that the frame finds "
              "them in the OS page cache (SQLite maps), once a place is in LTM; 0 = off; decisions "
              "never depend on it"),
      integer("place_lists_from", &Options::place_lists_from, 0, 100000000, "0..1e8",
              "from this many place codes on, each frame's place-code search scans the codes of "
              "one in 16 of place_lists_from/64 coarse centres, those nearest the frame's (an "
              "inverted file trained once on the codes of the map's first locations), not every "
              "code; 0 = every code always (the default: bench/scale/README.md has why). Below it "
              "nothing changes"),
      integer("wm_immune_newest", &Options::wm_immune_newest, 0, 100000, "0..100000",
              "newest WM locations never transferred (at least)"),
      real("wm_recent_ratio", &Options::wm_recent_ratio, 0, kBelowOne, "0..1, 1 excluded",
           "share of WM, the newest, never transferred (RTAB-Map's Mem/RecentWmRatio)"),
      real("t_loop", &Options::t_loop, 0, 1, "0..1", "loop-closure acceptance threshold"),
      choice("decision_rule", &Options::decision_rule, parseDecisionRule, "rtabmap|paper",
             "rtabmap: 1-p(new) >= t_loop and ratio test; paper: p(new) < t_loop"),
      real("loop_ratio", &Options::loop_ratio, 0, 1, "0..1",
           "rtabmap rule: reject when the score falls under this x the previous frame's"),
      real("prediction_sigma", &Options::prediction_sigma, 0.01, 100, "0.01..100",
           "Gaussian spread of the prediction over neighbouring locations, in links"),
      integer("prediction_links", &Options::prediction_links, 0, 1000, "0..1000",
              "links from a location that its prediction reaches"),
      integer("hypothesis_radius", &Options::hypothesis_radius, 0, 100, "0..100",
              "WM locations within this many links of the filter's best hypothesis compete with "
              "it in the geometric check (0 = the best hypothesis alone)"),
      integer("hypothesis_top_similar", &Options::hypothesis_top_similar, 0, 1000, "0..1000",
              "this many most similar WM locations also compete with the filter's best hypothesis"),
      choice("geometry_rule", &Options::geometry_rule, parseGeometryRule, "inliers|nfa|either",
             "how the geometric check decides: inliers (geometry_min_inliers pairs within "
             "geometry_max_error_px of one fundamental matrix), nfa (a contrario: "
             "geometry_max_nfa and geometry_min_overlap) or either of the two"),
      integer("geometry_min_inliers", &Options::geometry_min_inliers, 0, 10000, "0..10000",
              "inliers rule: epipolar inliers a loop-closure hypothesis needs; 0 = no geometric "
              "check"),
      real("geometry_max_nfa", &Options::geometry_max_nfa, 0, 1e12, "0..1e12",
           "nfa rule: a hypothesis passes when its best epipolar fit would arise by chance this "
           "many times or fewer (a contrario NFA); 0 = no geometric check"),
      real("geometry_min_overlap", &Options::geometry_min_overlap, 0, 1, "0..1",
           "nfa rule: the epipolar inliers must also be at least this share of the keypoints of "
           "the image or location with fewer of them"),
      real("geometry_max_error_px", &Options::geometry_max_error_px, 0.1, 100, "0.1..100",
           "geometric check: largest distance of a keypoint from its epipolar line that counts "
           "as agreement, in pixels"),
      real("geometry_max_error_diagonal", &Options::geometry_max_error_diagonal, 0, 1, "0..1",
           "geometric check: nor above this share of the image's diagonal (on small images), "
           "so that chance agreement stays as rare as on larger ones; 0 = "
           "geometry_max_error_px alone"),
      real("geometry_match_ratio", &Options::geometry_match_ratio, 0.1, 1, "0.1..1",
           "geometric check: nearest/second-nearest descriptor distance ratio for a match"),
      boolean("geometry_count_candidates", &Options::geometry_count_candidates,
              "geometric check: a frame's candidates are one family of tests, so each "
              "candidate's NFA is multiplied by their number, and the inliers rule also needs "
              "that product at most 1 (no acceptance at the level of chance)"),
      real("geometry_min_scene_share", &Options::geometry_min_scene_share, 0, 1, "0..1",
           "a place that passes the check on its own must also cover this share of the scene "
           "the frame shares with its own previous view (its pairs on planes, corrected for "
           "their number), or it shares an object, not the place; 0 = off"),
      integer("geometry_way_here_checks", &Options::geometry_way_here_checks, 0, 1000, "0..1000",
              "a closure that starts a run is refused when the frame agrees with its whole way "
              "back to the place (one scene, never left), or when one of this many places of "
              "that way, the most similar first, agrees about as well (a pattern that repeats "
              "along the route, not the place); 0 = off"),
      boolean("geometry_way_here_ranked", &Options::geometry_way_here_ranked,
              "those places weighed by their similarity rank (the j-th compared counts as j(j+1) "
              "tries, so more places compared only adds tests), an earlier visit of the place "
              "joined to it by a loop closure none of them, one that passes the bar itself "
              "refuting alone, and a refutation holding for the next frames that claim the "
              "place again; false: as sessions begun before it"),
      boolean("geometry_latest_view", &Options::geometry_latest_view,
              "a location keeps the keypoints of the latest frame merged into it beside its "
              "first frame's, and an accepted loop closure names, of the place and its "
              "traversal neighbours, the one whose views agree best with the frame (a location "
              "of several frames is otherwise seen from its first only); false: as sessions "
              "begun before it"),
      integer("temporal_min_inliers", &Options::temporal_min_inliers, 0, 10000, "0..10000",
              "inliers rule: inliers that suffice for a hypothesis near the last accepted loop "
              "closure (see temporal_radius, temporal_max_gap); 0 = off"),
      real("temporal_max_nfa", &Options::temporal_max_nfa, 0, 1e12, "0..1e12",
           "nfa rule: NFA that suffices for a hypothesis near the last accepted loop closure "
           "(with temporal_min_overlap); 0 = off"),
      real("temporal_min_overlap", &Options::temporal_min_overlap, 0, 1, "0..1",
           "nfa rule: inliers' share of the keypoints that such a hypothesis needs"),
      integer("temporal_radius", &Options::temporal_radius, 0, 100, "0..100",
              "WM links from the last loop closure that passed on its own within which the "
              "relaxed rule applies on the next frame; those locations are also checked as "
              "candidates"),
      integer("temporal_max_gap", &Options::temporal_max_gap, 1, 100, "1..100",
              "frames after that closure for which the relaxed rule still applies, later frames "
              "reaching temporal_radius + gap - 1 links ahead in the direction the closures "
              "move (1 = the next frame only)"),
      boolean("temporal_end_on_object", &Options::temporal_end_on_object,
              "a frame whose agreement with a place of the run shares one object, not the scene "
              "(geometry_min_scene_share), ends the run: later frames no longer pass the relaxed "
              "rule on it"),
      real("fx", &Options::fx, 0, 1e6, "0..1e6",
           "camera focal length along x in pixels; fx fy cx cy all four or none (0 = unknown): "
           "with them every accepted loop closure also stores its relative pose"),
      real("fy", &Options::fy, 0, 1e6, "0..1e6", "camera focal length along y in pixels"),
      real("cx", &Options::cx, 0, 1e6, "0..1e6", "camera principal point x in pixels"),
      real("cy", &Options::cy, 0, 1e6, "0..1e6", "camera principal point y in pixels"),
  };
  return rows;
}

const Row* find(const std::string& key) {
  for (const auto& r : table())
    if (key == r.key) return &r;
  return nullptr;
}

std::string knownKeys() {
  std::string keys;
  for (const auto& r : table()) keys += (keys.empty() ? "" : ", ") + std::string(r.key);
  return keys;
}

}  // namespace

const char* toString(Extractor extractor) { return nameOf(kExtractorNames, extractor); }
const char* toString(WordRule rule) { return nameOf(kWordRuleNames, rule); }
const char* toString(DistanceUnit unit) { return nameOf(kDistanceUnitNames, unit); }
const char* toString(DecisionRule rule) { return nameOf(kDecisionRuleNames, rule); }
const char* toString(GeometryRule rule) { return nameOf(kGeometryRuleNames, rule); }

Extractor parseExtractor(const std::string& text, const std::string& key) {
  return parseName<Extractor>(kExtractorNames, text, key);
}
WordRule parseWordRule(const std::string& text, const std::string& key) {
  return parseName<WordRule>(kWordRuleNames, text, key);
}
DistanceUnit parseDistanceUnit(const std::string& text, const std::string& key) {
  return parseName<DistanceUnit>(kDistanceUnitNames, text, key);
}
DecisionRule parseDecisionRule(const std::string& text, const std::string& key) {
  return parseName<DecisionRule>(kDecisionRuleNames, text, key);
}
GeometryRule parseGeometryRule(const std::string& text, const std::string& key) {
  return parseName<GeometryRule>(kGeometryRuleNames, text, key);
}

Options Options::fromSettings(const std::map<std::string, std::string>& settings,
                              const Options& base) {
  Options o = base;
  for (const auto& [key, value] : withAliasesResolved(settings)) {
    const Row* row = find(key);
    if (!row)
      throw Error(ErrorCode::kInvalidArgument,
                  fmt::format("unknown setting '{}'; known settings: {}", key, knownKeys()));
    row->set(o, value);
    if (!row->ok(o)) refuse(key, value, row->valid);
  }
  return o;
}

Options Options::fromSettings(const std::map<std::string, std::string>& settings) {
  return fromSettings(settings, Options());
}

Options Options::fromStoredSettings(const std::map<std::string, std::string>& settings) {
  Options before;
  before.feature_target = 0;
  before.feature_retry = 0.5;
  before.geometry_max_error_diagonal = 0;
  before.geometry_count_candidates = false;
  before.geometry_min_scene_share = 0;
  before.geometry_way_here_checks = 0;
  before.geometry_way_here_ranked = false;
  before.geometry_latest_view = false;
  before.temporal_end_on_object = false;
  return fromSettings(settings, before);
}

std::map<std::string, std::string> Options::toSettings() const {
  std::map<std::string, std::string> out;
  for (const auto& r : table()) out[r.key] = r.get(*this);
  return out;
}

void Options::validate() const {
  for (const auto& r : table())
    if (!r.ok(*this)) refuse(r.key, r.get(*this), r.valid);
  const int intrinsics = (fx != 0) + (fy != 0) + (cx != 0) + (cy != 0);
  if (intrinsics != 0 && intrinsics != 4)
    throw Error(ErrorCode::kInvalidArgument,
                fmt::format("camera intrinsics need all four of fx fy cx cy or none (0 = unknown); "
                            "got fx={} fy={} cx={} cy={}",
                            fx, fy, cx, cy));
  // Pixels are the unit: a focal length under one pixel makes one pixel span more than 45
  // degrees, which no camera does (a typo's 1e-3 or a value in metres would give nonsense poses).
  if (intrinsics == 4 && (fx < 1 || fy < 1))
    throw Error(ErrorCode::kInvalidArgument,
                fmt::format("fx and fy are focal lengths in pixels and must be at least 1 (a "
                            "smaller one makes one pixel span more than 45 degrees); got fx={} "
                            "fy={}",
                            fx, fy));
  if (t_nd1 > t_nd2)
    throw Error(ErrorCode::kInvalidArgument,
                fmt::format("t_nd1 ({}) must not exceed t_nd2 ({})", t_nd1, t_nd2));
}

Options Options::paperPreset() {
  Options o;
  o.t_sim = 0.2;
  o.t_loop = 0.11;
  o.t_nndr = 0.8;
  o.t_nd1 = 0.001;
  o.t_nd2 = 0.08;
  o.t_time_ms = 700;
  o.decision_rule = DecisionRule::kPaper;
  o.loop_ratio = 0.9;
  // The papers verify nothing: their hypothesis is the filter's best location, as it stands.
  o.hypothesis_radius = 0;
  o.hypothesis_top_similar = 0;
  o.geometry_min_inliers = 0;
  o.geometry_max_nfa = 0;
  o.temporal_min_inliers = 0;
  o.temporal_max_nfa = 0;
  return o;
}

std::vector<Options::SettingInfo> Options::catalogue() {
  std::vector<SettingInfo> out;
  Options defaults;
  for (const auto& r : table())
    out.push_back({r.key, r.get(defaults), r.valid, r.description, r.min, r.max});
  return out;
}

}  // namespace placedb
