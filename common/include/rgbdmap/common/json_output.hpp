#pragma once
// The JSON the programs write (report.json, client_<robot>.json, server_summary.json, `rgbdmap eval --json`):
// built as nlohmann::ordered_json (keys stay in insertion order) and printed by formatJson / compactJson,
// which lay it out as these files always were and print every floating-point number in its shortest form
// (nlohmann's own dump() prints some doubles with 17 digits, e.g. 0.23561 as 0.23561000000000001).
#include <string>

#include <nlohmann/json.hpp>

#include "rgbdmap/common/result.hpp"

namespace rgbdmap {

using Json = nlohmann::ordered_json;

/// `value` rounded to `digits` significant digits; formatJson / compactJson then print it as
/// printf("%.<digits>g") does (whole numbers that printf shows in full become JSON integers). NaN and
/// infinities become null (JSON has neither).
Json jsonNumber(double value, int digits = 6);

/// Two-space indentation, one member per line, except that arrays holding no objects and objects holding
/// only plain values stay on one line (`"frame_range": [0, 60]`, `{"robot": "a", "keyframes": 3}`); the top
/// level is always expanded. Ends with a newline.
std::string formatJson(const Json& value);

/// One line without spaces: {"a":1,"b":[0,1]} (no trailing newline).
std::string compactJson(const Json& value);

/// formatJson(value) written atomically (writeTextFileAtomic).
Status writeJsonFile(const std::string& path, const Json& value);

}  // namespace rgbdmap
