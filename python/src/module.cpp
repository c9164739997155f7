// The `placedb` Python module: the engine's public API (engine/include/placedb/map.h) for
// scripts that map image folders and evaluate in Python. Results are plain read-only objects;
// failures are placedb.Error subclasses carrying the command line's exit code (errors.h).
#include <pybind11/numpy.h>
#include <pybind11/pybind11.h>
#include <pybind11/stl.h>

#include <fmt/format.h>

#include <filesystem>
#include <map>
#include <memory>
#include <mutex>
#include <optional>
#include <string>
#include <vector>

#include "commands/map_summary.h"
#include "commands/vocab_transfer.h"
#include "errors.h"
#include "frame_names.h"
#include "images.h"
#include "map_rows.h"
#include "output_guard.h"
#include "placedb/error.h"
#include "placedb/map.h"
#include "placedb/options.h"
#include "placedb/version.h"
#include "sources/image_source.h"

namespace py = pybind11;

namespace placedb::python {
namespace {

// Settings from a dict of str, int, float or bool values, checked by Options::fromSettings.
Options optionsOf(const std::optional<py::dict>& settings) {
  std::map<std::string, std::string> text;
  if (settings) {
    for (const auto& [key, value] : *settings) {
      if (py::isinstance<py::bool_>(value))
        text[py::str(key)] = value.cast<bool>() ? "true" : "false";
      else
        text[py::str(key)] = py::str(value);
    }
  }
  return Options::fromSettings(text);
}

py::object jsonToPython(const nlohmann::json& value) {
  return py::module_::import("json").attr("loads")(value.dump());
}

// A read-only map opened without settings takes its last session's, as `placedb query` does:
// features extracted as they were mapped, and the camera's intrinsics for the poses of matches.
Options openingOptions(const std::string& path, const std::optional<py::dict>& settings,
                       bool read_only) {
  if (read_only && !settings) {
    try {
      if (auto stored = cli::lastSessionOptions(path)) return *stored;
    } catch (const Error&) {
      // A map that cannot be read this way: Map::open says why.
    }
  }
  return optionsOf(settings);
}

// A map as Python holds it: closing is explicit (close(), or leaving a `with` block) and any
// use afterwards is refused instead of reaching a closed engine.
//
// One Map may be shared between threads. The engine is not thread-safe and its calls release
// the GIL, so every call holds the Map's mutex while it runs: calls from several threads are
// serialised, and close() waits for the call in flight. The mutex is taken only with the GIL
// released (a thread waiting for it must not keep the thread that holds it from returning).
class PyMap {
 public:
  PyMap(const std::string& path, const std::optional<py::dict>& settings, bool read_only)
      : map_(Map::open(path, openingOptions(path, settings, read_only),
                       read_only ? Map::Mode::kLocalisation : Map::Mode::kMapping)) {}

  // Runs `call` on the open map, the GIL released and the mutex held.
  template <class Call>
  auto locked(Call&& call) {
    py::gil_scoped_release unlocked;
    std::lock_guard<std::mutex> lock(mutex_);
    if (!map_) throw Error(ErrorCode::kInvalidArgument, "the map is closed");
    return call(*map_);
  }

  SessionInfo beginSession(const std::string& source) {
    return locked([&](Map& map) {
      SessionInfo session = map.beginSession(source);
      next_index_ = 0;
      return session;
    });
  }

  SessionInfo resumeSession(std::int64_t id) {
    return locked([&](Map& map) {
      SessionInfo session = map.resumeSession(id);
      next_index_ = session.last_source_index ? *session.last_source_index + 1 : 0;
      return session;
    });
  }

  FrameResult process(const py::array& image, std::optional<std::int64_t> source_index,
                      const std::string& source_path, std::optional<std::int64_t> stamp_ns) {
    py::array contiguous;
    const cv::Mat mat = imageOf(image, contiguous);
    return locked([&](Map& map) {
      const std::int64_t index = source_index.value_or(next_index_);
      FrameResult result = map.process(mat, index, source_path, stamp_ns);
      next_index_ = index + 1;
      return result;
    });
  }

  // An image file read as `placedb map` reads it; an unreadable one is recorded as a bad frame.
  FrameResult processFile(const std::string& path, std::optional<std::int64_t> source_index) {
    return locked([&](Map& map) {
      const std::int64_t index = source_index.value_or(next_index_);
      std::string problem;
      const cv::Mat image = cli::readImageFile(path, problem);
      FrameResult result =
          image.empty() ? map.recordUnreadable(index, path) : map.process(image, index, path);
      next_index_ = index + 1;
      return result;
    });
  }

  QueryResult queryFile(const std::string& path, std::size_t top) {
    const cv::Mat image = readImage(path);
    return locked([&](Map& map) { return map.query(image, top); });
  }

  QueryResult query(const py::array& image, std::size_t top) {
    py::array contiguous;
    const cv::Mat mat = imageOf(image, contiguous);
    return locked([&](Map& map) { return map.query(mat, top); });
  }

  void close() {
    py::gil_scoped_release unlocked;
    std::lock_guard<std::mutex> lock(mutex_);
    if (map_) map_->close();
    map_.reset();
  }

 private:
  std::mutex mutex_;
  std::unique_ptr<Map> map_;
  std::int64_t next_index_ = 0;
};

std::string outcomeName(FrameOutcome outcome) {
  switch (outcome) {
    case FrameOutcome::kNewLocation:
      return "new_location";
    case FrameOutcome::kMerged:
      return "merged";
    case FrameOutcome::kBad:
      return "bad";
  }
  return "?";
}

bool isRtabmap(const std::string& format) {
  if (format != "placedb" && format != "rtabmap")
    throw Error(ErrorCode::kInvalidArgument,
                fmt::format("format {} is not valid (valid: placedb|rtabmap)", format));
  return format == "rtabmap";
}

std::size_t exportVocabulary(const std::string& map_path, const std::string& file,
                             const std::string& format) {
  const bool text = isRtabmap(format);
  cli::refuseMapAsOutput("vocab_export", map_path, file);
  const vocab::VocabularyData words = cli::wordsOfMap(map_path);
  cli::writeVocabulary(file, words, text);
  return words.ids.size();
}

std::size_t importVocabulary(const std::string& file, const std::string& map_path,
                             const std::string& mode, const std::string& format,
                             const std::string& extractor) {
  cli::VocabRequest request;
  request.file = file;
  request.map_path = map_path;
  request.mode = mode;
  request.text = isRtabmap(format);
  request.extractor = extractor;
  cli::runImport(request);
  return static_cast<std::size_t>(cli::inspectMap(map_path)["words"].get<std::int64_t>());
}

// A relative pose as Python sees it, under the names of `placedb query --json`: the quaternion
// in x, y, z, w order, as everywhere else, and the frame whose camera it is relative to (the
// location's first frame, map.h).
py::object poseDict(const std::optional<storage::ClosurePose>& pose,
                    const std::vector<FrameRef>& frames) {
  if (!pose) return py::none();
  py::dict d;
  d["rotation_xyzw"] = py::make_tuple(pose->qx, pose->qy, pose->qz, pose->qw);
  d["translation"] = py::make_tuple(pose->tx, pose->ty, pose->tz);
  d["inliers"] = pose->inliers;
  d["relative_to"] = frames.empty() ? py::object(py::none()) : py::cast(frames.front());
  return std::move(d);
}

std::string optionalText(const std::optional<std::int64_t>& value) {
  return value ? std::to_string(*value) : "None";
}

// Python's repr of a str: quotes and escapes as Python would write them.
std::string pyRepr(const std::string& text) { return py::repr(py::str(text)); }

std::string frameRepr(const FrameRef& f) {
  return fmt::format("FrameRef(session={}, index={}, stamp_ns={}, path={})", f.session_id,
                     f.source_index, optionalText(f.stamp_ns), pyRepr(f.source_path));
}

std::string framesRepr(const std::vector<FrameRef>& frames) {
  std::string text;
  for (const auto& f : frames) text += (text.empty() ? "" : ", ") + cli::frameName(f);
  return "[" + text + "]";
}

void bindResults(py::module_& m) {
  py::class_<FrameRef>(m, "FrameRef", "One input frame that a location covers")
      .def_readonly("frame_id", &FrameRef::frame_id)
      .def_readonly("session_id", &FrameRef::session_id)
      .def_readonly("source_index", &FrameRef::source_index)
      .def_readonly("source_path", &FrameRef::source_path)
      .def_readonly("stamp_ns", &FrameRef::stamp_ns,
                    "the source's stamp of the frame (a bag message's header.stamp, ns since the "
                    "epoch, or the stamp_ns given to process()); None without one")
      .def("__repr__", &frameRepr);
  py::class_<Hypothesis>(m, "Hypothesis", "The filter's best loop-closure candidate")
      .def_readonly("location_id", &Hypothesis::location_id, "0: no hypothesis")
      .def_readonly("frames", &Hypothesis::frames)
      .def_readonly("posterior", &Hypothesis::posterior)
      .def_readonly("score", &Hypothesis::score, "loop-closure probability")
      .def_readonly("accepted", &Hypothesis::accepted)
      .def_readonly("rejected_reason", &Hypothesis::rejected_reason)
      .def_readonly("inliers", &Hypothesis::inliers, "geometric check inliers, 0: no check")
      .def_readonly("matches", &Hypothesis::matches)
      .def_property_readonly(
          "pose", [](const Hypothesis& h) { return poseDict(h.pose, h.frames); },
          "an accepted closure's relative pose when the map has intrinsics (fx fy cx cy): "
          "{'rotation_xyzw': (qx, qy, qz, qw), 'translation': unit (tx, ty, tz), 'inliers': n, "
          "'relative_to': the FrameRef of the location's first frame, whose camera it is in} "
          "(quaternion x, y, z, w, as ROS and Eigen order it); None otherwise")
      .def("__repr__", [](const Hypothesis& h) {
        return fmt::format(
            "Hypothesis(location={}, frames={}, score={:.3f}, accepted={}, inliers={}{})",
            h.location_id, framesRepr(h.frames), h.score, h.accepted ? "True" : "False", h.inliers,
            h.accepted ? std::string() : ", rejected_reason=" + pyRepr(h.rejected_reason));
      });
  py::class_<StageTimes>(m, "StageTimes", "Milliseconds per stage")
      .def_readonly("features", &StageTimes::features)
      .def_readonly("quantisation", &StageTimes::quantisation)
      .def_readonly("likelihood", &StageTimes::likelihood)
      .def_readonly("filter", &StageTimes::filter)
      .def_readonly("memory", &StageTimes::memory)
      .def_readonly("storage", &StageTimes::storage)
      .def_readonly("total", &StageTimes::total)
      .def("__repr__", [](const StageTimes& t) {
        return fmt::format(
            "StageTimes(total={:.2f}, features={:.2f}, quantisation={:.2f}, likelihood={:.2f}, "
            "filter={:.2f}, memory={:.2f}, storage={:.2f})",
            t.total, t.features, t.quantisation, t.likelihood, t.filter, t.memory, t.storage);
      });
  py::class_<FrameResult>(m, "FrameResult", "What process() did with one image")
      .def_readonly("frame_id", &FrameResult::frame_id)
      .def_readonly("session_id", &FrameResult::session_id)
      .def_readonly("source_index", &FrameResult::source_index)
      .def_property_readonly(
          "outcome", [](const FrameResult& r) { return outcomeName(r.outcome); },
          "new_location, merged or bad")
      .def_readonly("location_id", &FrameResult::location_id, "0 when bad")
      .def_readonly("hypothesis", &FrameResult::hypothesis)
      .def_property_readonly("accepted", [](const FrameResult& r) { return r.hypothesis.accepted; })
      .def_property_readonly("score", [](const FrameResult& r) { return r.hypothesis.score; })
      .def_property_readonly("inliers", [](const FrameResult& r) { return r.hypothesis.inliers; })
      .def_property_readonly("matched_frames",
                             [](const FrameResult& r) { return r.hypothesis.frames; })
      .def_readonly("times", &FrameResult::times)
      .def_readonly("feature_count", &FrameResult::feature_count)
      .def_readonly("words_created", &FrameResult::words_created)
      .def_readonly("vocabulary_size", &FrameResult::vocabulary_size)
      .def_readonly("stm_size", &FrameResult::stm_size)
      .def_readonly("wm_size", &FrameResult::wm_size)
      .def_readonly("transferred", &FrameResult::transferred)
      .def_readonly("retrieved", &FrameResult::retrieved)
      .def_readonly("mean_quantisation_error", &FrameResult::mean_quantisation_error)
      .def_readonly("stamp_ns", &FrameResult::stamp_ns)
      .def("__repr__", [](const FrameResult& r) {
        return fmt::format(
            "FrameResult(frame={}, outcome={}, location={}, score={:.3f}, accepted={}, "
            "matched_frames={})",
            cli::frameName(r.session_id, r.source_index, r.stamp_ns),
            pyRepr(outcomeName(r.outcome)), r.location_id, r.hypothesis.score,
            r.hypothesis.accepted ? "True" : "False", framesRepr(r.hypothesis.frames));
      });
  py::class_<SessionInfo>(m, "SessionInfo")
      .def_readonly("id", &SessionInfo::id)
      .def_readonly("source", &SessionInfo::source)
      .def_readonly("started_at", &SessionInfo::started_at)
      .def_readonly("ended_at", &SessionInfo::ended_at)
      .def_readonly("clean_close", &SessionInfo::clean_close)
      .def_readonly("frames", &SessionInfo::frames)
      .def_readonly("last_source_index", &SessionInfo::last_source_index)
      .def("__repr__", [](const SessionInfo& i) {
        return fmt::format(
            "SessionInfo(id={}, source={}, frames={}, last_source_index={}, started_at={}, "
            "ended_at={}, clean_close={})",
            i.id, pyRepr(i.source), i.frames, optionalText(i.last_source_index),
            pyRepr(i.started_at), pyRepr(i.ended_at), i.clean_close ? "True" : "False");
      });
  // What `placedb query --json` holds, under the same names.
  py::class_<QueryMatch>(m, "QueryMatch")
      .def_readonly("location_id", &QueryMatch::location_id)
      .def_property_readonly(
          "tier", [](const QueryMatch& q) { return std::string(storage::toString(q.tier)); },
          "stm, wm or ltm")
      .def_readonly("similarity", &QueryMatch::similarity, "eq. 5 (LTM: 0 until checked)")
      .def_readonly("code_similarity", &QueryMatch::code_similarity)
      .def_readonly("inliers", &QueryMatch::inliers, "the geometric check's, 0 when it did not run")
      .def_readonly("verified", &QueryMatch::verified, "the geometric check passed")
      .def_readonly("frames", &QueryMatch::frames)
      .def_property_readonly(
          "pose", [](const QueryMatch& q) { return poseDict(q.pose, q.frames); },
          "a verified match's relative pose (the query's camera in that of the location's first "
          "frame, relative_to) when the map and the location's session have intrinsics, as "
          "Hypothesis.pose; None otherwise (no_pose_reason says why for a verified match)")
      .def_readonly("no_pose_reason", &QueryMatch::no_pose_reason,
                    "why a verified match has no pose; empty otherwise")
      .def("__repr__", [](const QueryMatch& q) {
        return fmt::format(
            "QueryMatch(location={}, tier={}, verified={}, inliers={}, code_similarity={:.3f}, "
            "frames={}, pose={})",
            q.location_id, storage::toString(q.tier), q.verified ? "True" : "False", q.inliers,
            q.code_similarity, framesRepr(q.frames),
            q.pose ? "{...}" : (q.verified ? "None: " + q.no_pose_reason : std::string("None")));
      });
  py::class_<QueryResult>(m, "QueryResult")
      .def_property_readonly(
          "verdict", [](const QueryResult& r) { return std::string(toString(r.verdict)); },
          "known (the best match passed the geometric check), unknown, or unverified (the "
          "map's settings switch the check off)")
      .def_readonly("feature_count", &QueryResult::feature_count)
      .def_readonly("matches", &QueryResult::matches, "best first: verified ones by inliers")
      .def_readonly("searched", &QueryResult::searched, "locations compared, all tiers")
      .def_readonly("checked", &QueryResult::checked, "candidates the geometric check ran on")
      .def_readonly("time_ms", &QueryResult::time_ms)
      .def("__repr__", [](const QueryResult& r) {
        std::string best = "None";
        if (!r.matches.empty())
          best = fmt::format("location {} {}", r.matches.front().location_id,
                             framesRepr(r.matches.front().frames));
        return fmt::format(
            "QueryResult(verdict={}, matches={}, best={}, searched={}, checked={}, "
            "feature_count={}, time_ms={:.1f})",
            pyRepr(toString(r.verdict)), r.matches.size(), best, r.searched, r.checked,
            r.feature_count, r.time_ms);
      });
}

std::string pathOf(PyMap& self) {
  return self.locked([](Map& map) { return map.path(); });
}

void bindMap(py::module_& m) {
  py::class_<PyMap>(
      m, "Map",
      "A placedb map file: Map(path, settings=None, read_only=False). read_only "
      "opens it for queries and never changes the file; without settings it "
      "takes the map's last session's, as `placedb query` does. One Map may be shared "
      "between threads: its calls run one at a time, and close() waits for the "
      "call in flight. To localise against a map being built, open a second, "
      "read-only Map on the same file.")
      .def(py::init<const std::string&, const std::optional<py::dict>&, bool>(), py::arg("path"),
           py::arg("settings") = py::none(), py::arg("read_only") = false)
      .def("begin_session", &PyMap::beginSession, py::arg("source"),
           "Starts a new session; source names where the images come from")
      .def("resume_session", &PyMap::resumeSession, py::arg("session_id"),
           "Continues an interrupted session with its own settings")
      .def("last_session",
           [](PyMap& self) { return self.locked([](Map& map) { return map.lastSession(); }); })
      .def("sessions",
           [](PyMap& self) { return self.locked([](Map& map) { return map.sessions(); }); })
      .def("process", &PyMap::process, py::arg("image"), py::arg("source_index") = py::none(),
           py::arg("source_path") = "", py::arg("stamp_ns") = py::none(),
           "Maps one numpy image (grey H x W, or BGR H x W x 3); commits it before returning. "
           "source_index defaults to the previous frame's plus one; stamp_ns (a bag message's "
           "header.stamp, ns since the epoch) is stored with the frame.")
      .def("process_file", &PyMap::processFile, py::arg("path"),
           py::arg("source_index") = py::none(),
           "Maps one image file; an unreadable file is recorded as a bad frame")
      .def("query", &PyMap::query, py::arg("image"), py::arg("top") = 5,
           "The stored locations that most resemble a numpy image, searched in every tier (STM, "
           "WM and LTM); changes nothing")
      .def("query_file", &PyMap::queryFile, py::arg("path"), py::arg("top") = 5,
           "query() on an image file, read as `placedb map` reads it; an unreadable file "
           "raises IoError")
      .def(
          "import_vocabulary",
          [](PyMap& self, const std::string& file, const std::string& mode,
             const std::string& format) {
            if (mode != "fixed" && mode != "seed")
              throw Error(ErrorCode::kInvalidArgument,
                          fmt::format("mode {} is not valid (valid: fixed|seed)", mode));
            return self.locked([&](Map& map) {
              return map.importVocabulary(
                  file, isRtabmap(format),
                  mode == "fixed" ? VocabularyMode::kFixed : VocabularyMode::kSeed);
            });
          },
          py::arg("file"), py::arg("mode") = "fixed", py::arg("format") = "placedb")
      .def_property_readonly(
          "settings",
          [](PyMap& self) {
            return self.locked([](Map& map) { return map.options().toSettings(); });
          })
      .def_property_readonly("path", [](PyMap& self) { return pathOf(self); })
      .def("info", [](PyMap& self) { return jsonToPython(cli::inspectMap(pathOf(self))); })
      .def("loop_closures", [](PyMap& self) { return loopClosureRows(pathOf(self)); })
      .def("close", &PyMap::close, "Ends the session cleanly; safe to call twice")
      .def("__enter__", [](PyMap& self) -> PyMap& { return self; })
      .def("__exit__", [](PyMap& self, const py::args&) { self.close(); });
}

}  // namespace
}  // namespace placedb::python

PYBIND11_MODULE(placedb, m) {
  using namespace placedb;
  using namespace placedb::python;
  m.doc() = "placedb: appearance-based loop-closure detection with a SQLite map";
  m.attr("__version__") = PLACEDB_VERSION_STRING;
  m.attr("__license__") = PLACEDB_LICENSE;
  registerErrors(m);
  bindResults(m);
  bindMap(m);
  m.def(
      "info", [](const std::string& path) { return jsonToPython(cli::inspectMap(path)); },
      py::arg("path"), "What `placedb info --json` prints, as a dict (read-only)");
  m.def(
      "image_paths",
      [](const std::string& source) {
        std::vector<std::string> images, skipped;
        if (std::filesystem::is_directory(source))
          cli::listImageFolder(source, images, skipped);
        else
          images = cli::readListFile(source);
        return images;
      },
      py::arg("source"),
      "The images of a folder (natural order) or a list file, as `placedb map` reads them");
  // A source's frames as `placedb map` reads them: folders, lists, videos, bags, cameras.
  py::class_<cli::ImageSource>(m, "Frames",
                               "The frames of a source, in order: iterate to get "
                               "(index, path, image, stamp_ns) tuples; image is None for a "
                               "frame that cannot be read")
      .def_property_readonly("kind", &cli::ImageSource::kind)
      .def_property_readonly("dropped", &cli::ImageSource::dropped,
                             "a live source's frames dropped while the caller was busy")
      .def("__len__",
           [](const cli::ImageSource& s) {
             if (!s.size()) throw py::type_error("a live source has no length");
             return *s.size();
           })
      .def(
          "__iter__", [](cli::ImageSource& s) -> cli::ImageSource& { return s; },
          py::return_value_policy::reference_internal)
      .def("__next__", [](cli::ImageSource& s) {
        cli::SourceFrame frame;
        bool more = false;
        {
          py::gil_scoped_release unlocked;  // a live source waits for its next frame
          more = s.read(frame);
        }
        if (!more) throw py::stop_iteration();
        return py::make_tuple(
            frame.index, frame.path,
            frame.image.empty() ? py::object(py::none()) : py::object(arrayOf(frame.image)),
            frame.stamp_ns ? py::object(py::int_(*frame.stamp_ns)) : py::object(py::none()));
      });
  m.def(
      "frames",
      [](const std::string& source, const std::string& topic, double fps) {
        cli::SourceOptions options;
        options.topic = topic;
        options.max_fps = fps;
        return cli::ImageSource::open(source, options);
      },
      py::arg("source"), py::arg("topic") = "", py::arg("fps") = 0.0,
      "The frames of an image folder, list file, video, ROS 1 or ROS 2 bag (topic: its image "
      "topic, default the only one), camera (camera:N, /dev/videoN) or stream (rtsp://, "
      "http://; fps caps the rate), as `placedb map` reads them");
  m.def(
      "read_image", [](const std::string& path) { return arrayOf(readImage(path)); },
      py::arg("path"),
      "An image file as `placedb map` reads it: a H x W x 3 uint8 BGR numpy array (IoError "
      "when it cannot be read)");
  m.def("loop_closures", &loopClosureRows, py::arg("path"),
        "The rows of the map's v_loop_closures view, as dicts (read-only)");
  m.def("settings", []() {
    py::list rows;
    for (const auto& s : Options::catalogue())
      rows.append(py::dict(py::arg("key") = s.key, py::arg("default") = s.default_value,
                           py::arg("valid") = s.valid, py::arg("description") = s.description));
    return rows;
  });
  m.def("vocab_export", &exportVocabulary, py::arg("map"), py::arg("file"),
        py::arg("format") = "placedb",
        "Writes every word of the map to file (placedb binary, or rtabmap text); returns the "
        "number of words");
  m.def("vocab_import", &importVocabulary, py::arg("file"), py::arg("map"),
        py::arg("mode") = "fixed", py::arg("format") = "placedb", py::arg("extractor") = "",
        "Starts a new map (or one without frames and words) from a vocabulary file; returns "
        "the number of words");
}
