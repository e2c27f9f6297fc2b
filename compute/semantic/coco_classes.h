#pragma once
// COCO's 80 object classes in the order of the detector's heatmap channels: darknet's
// `coco.names` (the 80 used classes, not the 90-id list with gaps), with a space inside a name
// written as '_' so that a name is one token in `masks/classes.txt` ("id class_name" lines).
#include <array>
#include <string>
#include <string_view>

namespace cofusion::semantic {

inline constexpr std::array<std::string_view, 80> kCocoClassNames = {
    "person",        "bicycle",      "car",           "motorbike",     "aeroplane",   "bus",
    "train",         "truck",        "boat",          "traffic_light", "fire_hydrant", "stop_sign",
    "parking_meter", "bench",        "bird",          "cat",           "dog",         "horse",
    "sheep",         "cow",          "elephant",      "bear",          "zebra",       "giraffe",
    "backpack",      "umbrella",     "handbag",       "tie",           "suitcase",    "frisbee",
    "skis",          "snowboard",    "sports_ball",   "kite",          "baseball_bat", "baseball_glove",
    "skateboard",    "surfboard",    "tennis_racket", "bottle",        "wine_glass",  "cup",
    "fork",          "knife",        "spoon",         "bowl",          "banana",      "apple",
    "sandwich",      "orange",       "broccoli",      "carrot",        "hot_dog",     "pizza",
    "donut",         "cake",         "chair",         "sofa",          "pottedplant", "bed",
    "diningtable",   "toilet",       "tvmonitor",     "laptop",        "mouse",       "remote",
    "keyboard",      "cell_phone",   "microwave",     "oven",          "toaster",     "sink",
    "refrigerator",  "book",         "clock",         "vase",          "scissors",    "teddy_bear",
    "hair_drier",    "toothbrush",
};

inline constexpr int kCocoPersonClass = 0;

// The class's name, or "class_<id>" outside 0..79.
std::string coco_class_name(int class_id);

}  // namespace cofusion::semantic
