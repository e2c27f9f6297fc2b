#pragma once
// The class table of instance masks: which class each mask id belongs to. Recorded sources read
// it from `classes.txt` inside their `masks/` folder, the synthetic generator writes it there, and
// `cofusion run --save-segmentation` writes one for its model ids. Format, one entry per line:
//   # comment
//   <id> <class_name>        id 0-65535 (0 = no instance), class_name one word, e.g. "3 can"
// Every error is a cofusion::Error naming the file (and line, or mask and id).
#include <cstdint>
#include <filesystem>
#include <map>
#include <string>

#include <opencv2/core.hpp>

namespace cofusion {

struct InstanceClasses {
  std::map<std::uint16_t, std::string> name_by_id;  // mask id -> class name
  std::string origin;  // the file or scene it came from, for messages

  // The class of `id`, or nullptr when the table has no line for it.
  const std::string* find(std::uint16_t id) const;
};

// File name of a class table inside a masks folder.
inline constexpr const char* kInstanceClassesFile = "classes.txt";

// True when `class_name` is one non-empty word of printable ASCII (no spaces: the file format
// splits on whitespace).
bool is_class_name(const std::string& class_name);
// `name` as one word: whitespace and other non-printable characters become '_' ("teddy bear" ->
// "teddy_bear"); empty becomes "unknown". For class names from elsewhere (a detector's labels).
std::string class_name_token(const std::string& name);
// Throws unless is_class_name(); `what` names its origin in the message.
void require_class_name(const std::string& class_name, const std::string& what);

// Reads a class table; throws naming the file and line on a line that does not parse, an id out of
// range or given twice, or a class name that is not one word.
InstanceClasses read_instance_classes(const std::filesystem::path& path);

// The file's text (a comment header, then "id class_name" by increasing id).
std::string format_instance_classes(const InstanceClasses& classes);
// Writes format_instance_classes() atomically.
void write_instance_classes(const std::filesystem::path& path, const InstanceClasses& classes);

// Throws naming `mask_path` and the id when a non-zero id of `mask` (CV_16UC1) has no class.
void require_mask_ids_classified(const cv::Mat& mask, const InstanceClasses& classes,
                                 const std::filesystem::path& mask_path);

}  // namespace cofusion
