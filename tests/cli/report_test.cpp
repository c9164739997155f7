// The parts of `placedb report` that need no map: base64, HTML escaping, the closures shown.
#include <gtest/gtest.h>

#include "base64.h"
#include "report/report.h"

namespace placedb::cli {
namespace {

std::string encode(const std::string& text) {
  return base64Encode(reinterpret_cast<const std::uint8_t*>(text.data()), text.size());
}

TEST(Base64, Rfc4648Vectors) {
  EXPECT_EQ(encode(""), "");
  EXPECT_EQ(encode("f"), "Zg==");
  EXPECT_EQ(encode("fo"), "Zm8=");
  EXPECT_EQ(encode("foo"), "Zm9v");
  EXPECT_EQ(encode("foob"), "Zm9vYg==");
  EXPECT_EQ(encode("fooba"), "Zm9vYmE=");
  EXPECT_EQ(encode("foobar"), "Zm9vYmFy");
  EXPECT_EQ(base64Encode(std::vector<std::uint8_t>{0xff, 0xfe, 0x00}), "//4A");
}

TEST(HtmlEscape, MarkupCharacters) {
  EXPECT_EQ(htmlEscape("a<b>&\"c'"), "a&lt;b&gt;&amp;&quot;c&#39;");
  EXPECT_EQ(htmlEscape("plain/path 1.png"), "plain/path 1.png");
}

ScoredFrame closure(std::int64_t frame, std::vector<std::int64_t> candidates, bool correct) {
  ScoredFrame f;
  f.frame = frame;
  f.candidates = std::move(candidates);
  f.score = 0.5;
  f.accepted = true;
  f.correct = correct;
  return f;
}

TEST(ClosureGallery, WrongFirstRightSampledOverTheRun) {
  Evaluation eval;
  eval.figures.window = 1;
  GroundTruth gt;
  // Frames 100..139 close right (their truth is frame - 100; the first candidate is off, the
  // second within the window); 150 and 160 close wrong; 170 is not accepted.
  for (std::int64_t f = 100; f < 140; ++f) {
    eval.frames.push_back(closure(f, {f - 50, f - 99}, true));
    gt[f] = {f - 100};
  }
  eval.frames.push_back(closure(150, {3}, false));
  gt[150] = {40};
  eval.frames.push_back(closure(160, {4}, false));
  ScoredFrame not_accepted = closure(170, {1}, false);
  not_accepted.accepted = false;
  eval.frames.push_back(not_accepted);

  const Gallery g = closureGallery(eval, gt, 1, 5);
  EXPECT_EQ(g.wrong_total, 2u);
  ASSERT_EQ(g.wrong.size(), 1u);
  EXPECT_EQ(g.wrong[0].frame, 150);
  EXPECT_EQ(g.wrong[0].matched, 3);
  EXPECT_EQ(g.wrong[0].truth, std::vector<std::int64_t>({40}));
  EXPECT_EQ(g.right_total, 40u);
  ASSERT_EQ(g.right.size(), 5u);
  EXPECT_EQ(g.right.front().frame, 100);
  EXPECT_EQ(g.right.back().frame, 139);
  for (const auto& e : g.right) EXPECT_EQ(e.matched, e.frame - 99) << "the right candidate";
  for (std::size_t i = 1; i < g.right.size(); ++i)
    EXPECT_GT(g.right[i].frame, g.right[i - 1].frame);

  const Gallery all = closureGallery(eval, gt, 10, 100);
  EXPECT_EQ(all.wrong.size(), 2u);
  EXPECT_EQ(all.right.size(), 40u);
}

}  // namespace
}  // namespace placedb::cli
