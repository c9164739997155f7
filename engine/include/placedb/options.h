#pragma once
// Every setting of the engine, typed, with its published or measured default.
// The same settings travel as text (`--set key=value`, config files, the map's settings table):
// Options::fromSettings() validates them, Options::toSettings() writes them back.
#include <cstdint>
#include <map>
#include <string>
#include <vector>

namespace placedb {

// The choices among settings. Their text forms (toString) are what `--set`, config files and the
// map's settings table hold; parsing is strict: any other text is refused, never defaulted.
enum class Extractor : std::uint8_t { kSurf, kSift, kKaze };
enum class WordRule : std::uint8_t { kGreedy = 0, kNndr = 1 };
enum class DistanceUnit : std::uint8_t { kSquared = 0, kEuclidean = 1 };
enum class DecisionRule : std::uint8_t {
  kRtabmap,  // accept when 1 - p(new) >= t_loop, unless the ratio test fails (RTAB-Map 2013)
  kPaper,    // accept when p(new) < t_loop (paper 000's wording), no ratio test
};

// How the epipolar check decides (engine/src/geometry/geometric_check.h).
enum class GeometryRule : std::uint8_t {
  kInliers,  // the most pairs one model puts within geometry_max_error_px >= min_inliers
  kNfa,      // a contrario: NFA <= geometry_max_nfa and enough overlap
  kEither,   // either of the two
};

const char* toString(Extractor extractor);  // "surf", "sift", "kaze"
const char* toString(WordRule rule);        // "greedy", "nndr"
const char* toString(DistanceUnit unit);    // "squared", "euclidean"
const char* toString(DecisionRule rule);    // "rtabmap", "paper"
const char* toString(GeometryRule rule);    // "inliers", "nfa", "either"
// Throw placedb::Error(kInvalidArgument) naming `key`, the text and the valid names.
Extractor parseExtractor(const std::string& text, const std::string& key = "extractor");
WordRule parseWordRule(const std::string& text, const std::string& key = "word_rule");
DistanceUnit parseDistanceUnit(const std::string& text, const std::string& key = "distance_unit");
DecisionRule parseDecisionRule(const std::string& text, const std::string& key = "decision_rule");
GeometryRule parseGeometryRule(const std::string& text, const std::string& key = "geometry_rule");

// Every component (features, vocabulary, filter, memory tiers, geometric check) takes its
// settings from here through engine/option_mapping; their own structs default to these values.
struct Options {
  // --- features (SPEC §1) ---
  Extractor extractor = Extractor::kSurf;
  double hessian_threshold = 60;  // SURF fast-Hessian threshold (measured, bench/quality)
  int octaves = 4;                // SURF octaves
  int intervals = 2;              // SURF intervals (layers) per octave
  bool upright = false;           // U-SURF: no orientation
  int max_features = 600;         // strongest kept; 0 keeps all
  int feature_target = 100;       // fewer (x feature_retry): detect again at twice the size
  double feature_retry = 1;       // share of feature_target under which that is done, 0 = off
  double min_response = 0;        // features under this response are dropped
  double bad_ratio = 0.25;        // fewer features than this x running mean: a bad frame

  // --- vocabulary (SPEC §2) ---
  WordRule word_rule = WordRule::kGreedy;
  DistanceUnit distance_unit = DistanceUnit::kSquared;  // unit of t_nd1, t_nd2 and the ratio
  double t_nndr = 0.9;  // paper 0.8; 0.9 measured better (bench/quality)
  double t_nd1 = 0.001;
  double t_nd2 = 0.08;
  int kd_trees = 4;
  int kd_checks = 64;

  // --- memory (SPEC §5, §7) ---
  int stm_size = 20;             // newest locations that are never loop candidates
  double t_sim = 0.2;            // merge into the previous location above this similarity
  int wm_max = 0;                // WM size limit, 0 = unbounded
  double t_time_ms = 0;          // limit on the frame's memory-bound stages (LTM search,
                                 // likelihood, filter update, retrieval) that triggers
                                 // transfer, 0 = off; features and verification excluded
  int wm_min = 100;              // the time limit never shrinks WM below this
  int max_retrieved = 2;         // LTM neighbours of the hypothesis brought back per frame
  int ltm_search = 5;            // places most like the frame by place code (WM and LTM);
                                 // those in LTM come back to WM first, 0 = off
  int read_ahead_links = 1;      // the places the next frame may bring back from LTM (and
                                 // those this many links from them) are read on a thread into
                                 // the OS page cache (SQLite maps), 0 = off
  int place_lists_from = 0;      // from this many place codes on, the place-code search of each
                                 // frame probes an inverted file instead of reading every code
                                 // (memory/place_lists.h); 0 = always every code, the default:
                                 // on the codes measured so far an index that keeps 99 % of the
                                 // exact top 5 reads most codes anyway (bench/scale/README.md)
  int wm_immune_newest = 0;      // newest WM locations never transferred (at least)
  double wm_recent_ratio = 0.2;  // ... or this share of WM, whichever is more

  // --- Bayes filter and decision (SPEC §6) ---
  double t_loop = 0.03;  // paper 0.11; the geometric check guards acceptance
  DecisionRule decision_rule = DecisionRule::kRtabmap;
  double loop_ratio = 0;  // rtabmap rule: reject when score < ratio x previous score
                          // (RTAB-Map 2013: 0.9; 0 = off, the geometric check replaces it)
  double prediction_sigma = 1.6;
  int prediction_links = 16;

  // --- hypothesis verification (RTAB-Map's later releases; not in the two papers) ---
  int hypothesis_radius = 3;       // WM locations this many links from the filter's best
                                   // hypothesis compete with it; the check picks among them
  int hypothesis_top_similar = 5;  // ... and so do this many most similar WM locations
  GeometryRule geometry_rule = GeometryRule::kNfa;  // how the epipolar check decides
                                                    // (geometric_check.h)
  int geometry_min_inliers = 13;       // inliers rule: pairs one fundamental matrix must put
                                       // within geometry_max_error_px; 0 = no check
  double geometry_max_nfa = 0.001;     // nfa rule: a contrario number of false alarms at most;
                                       // 0 = no check
  double geometry_min_overlap = 0.05;  // nfa rule: and inliers at least this share of keypoints
  double geometry_max_error_px = 3.0;  // epipolar distances above this never count as agreement
  double geometry_max_error_diagonal = 0.01;  // ... nor above this share of the image's
                                              // diagonal (small images); 0 = pixels alone
  double geometry_match_ratio = 0.8;          // descriptor ratio test for the check's matches
  // A frame's candidates are one family of tests: each candidate's NFA is multiplied by their
  // number, and the inliers rule also needs that product at most 1 (false: each place alone).
  bool geometry_count_candidates = true;
  // A place that passes on its own must cover at least this share of the frame's scene with its
  // agreeing pairs, or it shares an object, not the place (engine/src/geometry/scene_extent.h);
  // 0 = off.
  double geometry_min_scene_share = 0.25;
  // A closure that starts a run must be what the frame's agreement singles out: refused when the
  // frame agrees with its whole way back to the place (one scene, never left), or when one of
  // this many places of its way here, the most similar first, agrees about as well (a pattern
  // that repeats along the route; engine/src/decision/way_here.h); 0 = off.
  int geometry_way_here_checks = 8;
  // The places compared weighed by their rank, an earlier visit of the place no impostor, an
  // impostor that passes the bar refuting alone, and a refutation carrying over to the next
  // frames that claim the place (way_here.h); false: as sessions begun before it judged.
  bool geometry_way_here_ranked = true;
  // A location keeps the view of the latest frame merged into it beside its first frame's, and
  // an accepted closure names the place whose views agree best with the frame
  // (engine/src/geometry/latest_view.h); false: its first frame's view only.
  bool geometry_latest_view = true;

  // --- temporal consistency (iBoW-LCD's islands; RTAB-Map's closures that follow the graph) ---
  // A hypothesis that misses the check's rule still passes a relaxed one (temporal_min_inliers,
  // or temporal_max_nfa and temporal_min_overlap) when it continues the run of loop closures the
  // camera is making (engine/src/decision/closure_run.h): within temporal_radius WM links of the
  // run's last closure that passed on its own, on the next frame; up to temporal_max_gap frames
  // later, within temporal_radius + gap - 1 links ahead of it in the run's heading. Those
  // locations are checked as candidates too.
  int temporal_min_inliers = 7;         // inliers rule (and either); 0 = off
  double temporal_max_nfa = 100;        // nfa rule (and either); 0 = off
  double temporal_min_overlap = 0.025;  // nfa rule (and either)
  int temporal_radius = 2;              // links from the last closure that passed on its own
  int temporal_max_gap = 4;             // frames since that closure (1 = the previous frame's)
  // A frame whose agreement with a place of the run is one object, not its scene
  // (geometry_min_scene_share), ends the run: the camera has left the places it follows.
  bool temporal_end_on_object = true;

  // --- running ---
  // Worker threads of feature extraction, quantisation, the place-code scan and the geometric
  // checks of a frame's candidates (two at a time once the first has failed), 0 = one per
  // hardware thread. The work is split so that results never depend on it: any value gives the
  // same decisions. The threads beside the caller's start on first use and stay for the life of
  // the process, shared by every map in it (a forked child starts its own).
  int threads = 2;

  // --- camera intrinsics (optional) ---
  // The pinhole camera of the images as they are mapped, in pixels: all four or none (0 =
  // unknown). With them each accepted loop closure also stores its relative pose, from an
  // essential matrix fitted to the geometric check's pairs (schema 7); which closures are
  // accepted does not change. A session keeps the ones it began with.
  double fx = 0;  // focal lengths
  double fy = 0;
  double cx = 0;  // principal point
  double cy = 0;
  bool hasIntrinsics() const { return fx > 0 && fy > 0; }

  // Throws placedb::Error(kInvalidArgument) naming the key and the valid values or range;
  // an unknown key is refused with the list of known ones.
  static Options fromSettings(const std::map<std::string, std::string>& settings,
                              const Options& base);
  static Options fromSettings(const std::map<std::string, std::string>& settings);
  // A session's settings as a map stored them: a setting added after that session began takes
  // the value that reproduces it (feature_target 0, feature_retry 0.5, geometry_max_error_diagonal
  // 0, geometry_count_candidates false, geometry_min_scene_share 0, geometry_way_here_checks 0,
  // geometry_way_here_ranked false, geometry_latest_view false, temporal_end_on_object false), so
  // a resumed session decides as it did.
  static Options fromStoredSettings(const std::map<std::string, std::string>& settings);
  std::map<std::string, std::string> toSettings() const;
  void validate() const;

  // Paper 000, table 4: T_sim 0.2, T_loop 0.11, T_NNDR 0.8, T_ND1 0.001, T_ND2 0.08,
  // T_time 0.7 s (1 Hz), the paper's decision rule.
  static Options paperPreset();

  struct SettingInfo {
    std::string key;
    std::string default_value;
    std::string valid;  // "0..1", "greedy|nndr", ...
    std::string description;
    // Numeric settings: the accepted closed range (an open end is the nearest value inside);
    // min > max for choices and booleans.
    double min = 1;
    double max = 0;
  };
  static std::vector<SettingInfo> catalogue();

  // RTAB-Map parameter names accepted in place of the setting that means the same
  // ("Rtabmap/LoopThr" -> "t_loop"). fromSettings takes them; toSettings writes our keys.
  struct SettingAlias {
    std::string alias;
    std::string key;
  };
  static std::vector<SettingAlias> aliases();
};

}  // namespace placedb
