// Class tables of instance masks (classes.txt): parsing, writing, and the per-mask id check.
#include "io/instance_classes.h"

#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include "common/error.h"
#include "io_fixtures.h"
#include "support/test_support.h"

namespace cofusion {
namespace {
namespace fs = std::filesystem;
using ::testing::HasSubstr;
using test::error_of;

TEST(InstanceClasses, ReadsIdsAndNamesSkippingComments) {
  const fs::path path = test::fresh_temp_dir() / "classes.txt";
  test::write_text(path, "# id class_name\r\n\n  0 background\n7 can # lifted at frame 20\r\n65535 person\n");
  const InstanceClasses c = read_instance_classes(path);
  const std::map<std::uint16_t, std::string> expected{{0, "background"}, {7, "can"}, {65535, "person"}};
  EXPECT_EQ(c.name_by_id, expected);
  EXPECT_EQ(c.origin, path.string());
  ASSERT_NE(c.find(7), nullptr);
  EXPECT_EQ(*c.find(7), "can");
  EXPECT_EQ(c.find(8), nullptr);
}

TEST(InstanceClasses, WrittenFileReadsBack) {
  const fs::path path = test::fresh_temp_dir() / "classes.txt";
  InstanceClasses c;
  c.name_by_id = {{2, "ball"}, {1, "box"}, {300, "arm"}};
  write_instance_classes(path, c);
  EXPECT_EQ(read_instance_classes(path).name_by_id, c.name_by_id);
  EXPECT_THAT(format_instance_classes(c), HasSubstr("1 box\n2 ball\n300 arm\n"));  // by id
  c.name_by_id[4] = "teddy bear";
  EXPECT_THAT(error_of([&] { write_instance_classes(path, c); }), HasSubstr("id 4"));
}

TEST(InstanceClasses, BadLinesNameFileAndLine) {
  const fs::path dir = test::fresh_temp_dir();
  const std::pair<std::string, std::string> cases[] = {
      {"1 box\nbox 1\n", ":2: 'box' is not a mask id"},
      {"1\n", ":1: expected 'id class_name'"},
      {"1 teddy bear\n", ":1: expected 'id class_name'"},
      {"65536 box\n", ":1: '65536' is not a mask id"},
      {"-1 box\n", ":1: '-1' is not a mask id"},
      {"1.5 box\n", ":1: '1.5' is not a mask id"},
      {"3 box\n3 can\n", ":2: id 3 is listed twice"},
  };
  for (const auto& [text, expected] : cases) {
    const fs::path path = dir / "classes.txt";
    test::write_text(path, text);
    EXPECT_THAT(error_of([&] { read_instance_classes(path); }), HasSubstr(path.string() + expected)) << text;
  }
  EXPECT_THAT(error_of([&] { read_instance_classes(dir / "missing.txt"); }), HasSubstr("missing.txt"));
}

TEST(InstanceClasses, MaskIdsWithoutAClassAreNamedWithTheMask) {
  InstanceClasses c;
  c.name_by_id = {{1, "box"}, {2, "can"}};
  c.origin = "masks/classes.txt";
  cv::Mat mask(4, 6, CV_16UC1, cv::Scalar(0));
  mask.at<std::uint16_t>(0, 0) = 1;
  mask.at<std::uint16_t>(3, 5) = 2;
  EXPECT_NO_THROW(require_mask_ids_classified(mask, c, "masks/a.png"));
  mask.at<std::uint16_t>(2, 4) = 400;
  const std::string msg = error_of([&] { require_mask_ids_classified(mask, c, "masks/a.png"); });
  EXPECT_THAT(msg, HasSubstr("masks/a.png"));
  EXPECT_THAT(msg, HasSubstr("id 400 (pixel 4,2)"));
  EXPECT_THAT(msg, HasSubstr("masks/classes.txt"));
}

TEST(InstanceClasses, ClassNamesAreOneWord) {
  EXPECT_TRUE(is_class_name("teddy_bear"));
  EXPECT_FALSE(is_class_name(""));
  EXPECT_FALSE(is_class_name("teddy bear"));
  EXPECT_FALSE(is_class_name("tab\tbed"));
  EXPECT_EQ(class_name_token("teddy bear"), "teddy_bear");
  EXPECT_EQ(class_name_token(""), "unknown");
  EXPECT_EQ(class_name_token("can"), "can");
}

}  // namespace
}  // namespace cofusion
