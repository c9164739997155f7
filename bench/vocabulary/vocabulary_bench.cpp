// Grows a vocabulary by `per-frame` words a frame for `frames` frames (default 500 x 2000 = 1M
// words) and prints the per-frame quantise+add time (p50, p99, max) and the nearest-neighbour
// recall of the index against brute force for several `checks`.
//
// Data: random 64-d unit vectors around fixed cluster centres (each image draws its features from
// a few hundred centres, as views of one place share structure), which has the nearest-neighbour
// distance spread of SURF descriptors far better than uniform noise.
//
// Usage: vocabulary_bench [--frames N] [--per-frame M] [--queries Q] [--rule greedy|nndr]
#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <ctime>
#include <random>
#include <string>
#include <vector>

#include "vocabulary/vocabulary.h"

using placedb::vocab::Quantization;
using placedb::vocab::squaredDistance;
using placedb::vocab::Vocabulary;
using placedb::vocab::VocabularyOptions;
using placedb::vocab::WordRule;

namespace {

constexpr int kDim = 64;

class ClusteredDescriptors {
 public:
  ClusteredDescriptors(std::uint32_t seed, int centres)
      : rng_(seed), centres_(centres, kDim, CV_32F) {
    std::normal_distribution<float> gauss(0.f, 1.f);
    for (int i = 0; i < centres; ++i) {
      for (int d = 0; d < kDim; ++d) centres_.at<float>(i, d) = gauss(rng_);
      cv::normalize(centres_.row(i), centres_.row(i));
    }
  }
  // One image: features around `per_image_centres` centres, noise of norm ~0.2 (two views of a
  // centre are ~0.28 apart, T_ND2 = 0.08 squared).
  cv::Mat image(int n, int per_image_centres) {
    std::uniform_int_distribution<int> any_centre(0, centres_.rows - 1);
    std::vector<int> picked(per_image_centres);
    for (int& c : picked) c = any_centre(rng_);
    std::uniform_int_distribution<int> pick(0, per_image_centres - 1);
    std::normal_distribution<float> noise(0.f, noise_);
    cv::Mat out(n, kDim, CV_32F);
    for (int i = 0; i < n; ++i) {
      const int c = picked[pick(rng_)];
      for (int d = 0; d < kDim; ++d) out.at<float>(i, d) = centres_.at<float>(c, d) + noise(rng_);
      cv::normalize(out.row(i), out.row(i));
    }
    return out;
  }

 public:
  // New views of known words: the word plus the same noise as an image's features.
  cv::Mat viewsOf(const Vocabulary& vocabulary, const std::vector<std::int64_t>& ids, int n) {
    std::uniform_int_distribution<std::size_t> pick(0, ids.size() - 1);
    std::normal_distribution<float> noise(0.f, noise_);
    cv::Mat out(n, kDim, CV_32F);
    for (int i = 0; i < n; ++i) {
      const float* w = vocabulary.descriptor(ids[pick(rng_)]);
      for (int d = 0; d < kDim; ++d) out.at<float>(i, d) = w[d] + noise(rng_);
      cv::normalize(out.row(i), out.row(i));
    }
    return out;
  }

 private:
  static constexpr float noise_ = 0.025f;
  std::mt19937 rng_;
  cv::Mat centres_;
};

// CPU time of this thread: the machine is shared, so wall time also measures the neighbours.
double threadCpuMs() {
  timespec ts{};
  clock_gettime(CLOCK_THREAD_CPUTIME_ID, &ts);
  return double(ts.tv_sec) * 1e3 + double(ts.tv_nsec) * 1e-6;
}

double percentile(std::vector<double> v, double p) {
  std::sort(v.begin(), v.end());
  return v[std::min(v.size() - 1, std::size_t(p * double(v.size() - 1) + 0.5))];
}

// Fraction of queries (new views of words in RAM) whose approximate nearest word is the exact
// one (ties: same distance).
void printRecall(Vocabulary& vocabulary, ClusteredDescriptors& source, int queries) {
  const std::vector<std::int64_t> ids = vocabulary.ids();
  cv::Mat q = source.viewsOf(vocabulary, ids, queries);
  std::vector<float> exact(queries, INFINITY);
  const auto start = std::chrono::steady_clock::now();
  for (std::int64_t id : ids) {
    const float* w = vocabulary.descriptor(id);
    for (int i = 0; i < queries; ++i) {
      exact[i] = std::min(exact[i], squaredDistance(q.ptr<float>(i), w, kDim));
    }
  }
  const double brute_ms =
      std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - start).count();
  std::printf("  recall@1 over %zu words, %d queries (brute force %.0f ms/query):\n", ids.size(),
              queries, brute_ms / queries);
  const int default_checks = vocabulary.options().checks;
  for (int checks : {16, 32, 64, 96, 128, 256}) {
    vocabulary.setChecks(checks);
    int hits = 0;
    const auto t0 = std::chrono::steady_clock::now();
    for (int i = 0; i < queries; ++i) {
      const auto nn = vocabulary.knn(q.ptr<float>(i), 1);
      hits += !nn.empty() && nn[0].second * nn[0].second <= exact[i] * (1 + 1e-6f);
    }
    const double us =
        std::chrono::duration<double, std::micro>(std::chrono::steady_clock::now() - t0).count();
    std::printf("    checks %4d: recall %.3f, %.1f us/query%s\n", checks, double(hits) / queries,
                us / queries, checks == default_checks ? "  (default)" : "");
  }
  vocabulary.setChecks(default_checks);
}

}  // namespace

int main(int argc, char** argv) {
  int frames = 2000, per_frame = 500, queries = 200;
  VocabularyOptions options;
  for (int i = 1; i + 1 < argc; i += 2) {
    const std::string flag = argv[i];
    if (flag == "--frames")
      frames = std::atoi(argv[i + 1]);
    else if (flag == "--per-frame")
      per_frame = std::atoi(argv[i + 1]);
    else if (flag == "--queries")
      queries = std::atoi(argv[i + 1]);
    else if (flag == "--checks")
      options.checks = std::atoi(argv[i + 1]);
    else if (flag == "--leaf")
      options.leaf_size = std::atoi(argv[i + 1]);
    else if (flag == "--trees")
      options.kd_trees = std::atoi(argv[i + 1]);
    else if (flag == "--rule")
      options.rule = std::string(argv[i + 1]) == "nndr" ? WordRule::kNndr : WordRule::kGreedy;
    else {
      std::fprintf(stderr, "unknown flag %s\n", flag.c_str());
      return 2;
    }
  }
  std::printf(
      "vocabulary bench: %d frames x %d words, dim %d, rule %s, trees %d, checks %d, leaf %d\n",
      frames, per_frame, kDim, toString(options.rule), options.kd_trees, options.checks,
      options.leaf_size);
  Vocabulary vocabulary(options, kDim, "bench");
  ClusteredDescriptors source(2026, 200000);
  std::vector<double> frame_ms, frame_cpu_ms;
  frame_ms.reserve(frames);
  frame_cpu_ms.reserve(frames);
  double error_sum = 0;
  std::size_t created_total = 0;
  for (int f = 0; f < frames; ++f) {
    const cv::Mat image = source.image(per_frame, 150);
    const double cpu_start = threadCpuMs();
    const auto start = std::chrono::steady_clock::now();
    const Quantization q = vocabulary.quantize(image, f);
    // Features that reused a word are added as words too, so the vocabulary grows by exactly
    // per_frame words a frame (the benchmark's load, not the engine's behaviour).
    std::vector<std::int64_t> ids, created_frames;
    cv::Mat rows;
    std::vector<bool> is_new(per_frame, false);
    for (std::size_t i = 0; i < q.word_of_feature.size(); ++i) {
      if (q.distance_of_feature[i] == 0.f) is_new[i] = true;
    }
    std::int64_t next = vocabulary.nextWordId();
    for (int i = 0; i < per_frame; ++i) {
      if (is_new[i]) continue;
      ids.push_back(next++);
      created_frames.push_back(f);
      rows.push_back(image.row(i));
    }
    vocabulary.insert(ids, rows, created_frames);
    frame_ms.push_back(
        std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - start)
            .count());
    frame_cpu_ms.push_back(threadCpuMs() - cpu_start);
    error_sum += q.mean_error;
    created_total += q.created_words.size();
    if ((f + 1) % (frames / 10 > 0 ? frames / 10 : 1) == 0) {
      std::vector<double> last(frame_ms.end() - std::min<std::size_t>(frame_ms.size(), 200),
                               frame_ms.end());
      std::printf("frame %5d: %8zu words, last-200 p50 %.2f ms, max %.2f ms\n", f + 1,
                  vocabulary.size(), percentile(last, 0.5), percentile(last, 1.0));
      std::fflush(stdout);
    }
    if (f + 1 == frames / 10) printRecall(vocabulary, source, queries);
  }
  const double p50 = percentile(frame_ms, 0.5), p99 = percentile(frame_ms, 0.99);
  const double max_ms = percentile(frame_ms, 1.0);
  std::printf(
      "per-frame quantise+add over %d frames: p50 %.2f ms, p99 %.2f ms (%.2f x p50), max %.2f ms\n",
      frames, p50, p99, p99 / p50, max_ms);
  std::printf("same, thread CPU time: p50 %.2f ms, p99 %.2f ms (%.2f x p50), max %.2f ms\n",
              percentile(frame_cpu_ms, 0.5), percentile(frame_cpu_ms, 0.99),
              percentile(frame_cpu_ms, 0.99) / percentile(frame_cpu_ms, 0.5),
              percentile(frame_cpu_ms, 1.0));
  std::printf("targets (wall): p99 <= 3 x p50: %s; max < 100 ms: %s\n",
              p99 <= 3 * p50 ? "met" : "MISSED", max_ms < 100 ? "met" : "MISSED");
  std::printf("rule's own words: %zu created by quantize (%.1f%%), mean quantisation error %.4f\n",
              created_total, 100.0 * double(created_total) / (double(frames) * per_frame),
              error_sum / frames);
  std::printf("index state: %zu internal kd-tree nodes (%zu bytes serialised)\n",
              vocabulary.state().nodes.size(), vocabulary.state().serialize().size());
  printRecall(vocabulary, source, queries);
  return 0;
}
