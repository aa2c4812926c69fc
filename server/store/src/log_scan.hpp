#pragma once
// Internal: reading a whole log file at open, record by record, with the recovery rules of
// server/store/README.md (skip what does not verify, resynchronise after a damaged header, report an
// incomplete tail for the caller to cut off).
#include <cstddef>
#include <cstdint>
#include <functional>
#include <string>
#include <vector>

#include "rgbdmap/common/result.hpp"
#include "store_codec.hpp"

namespace rgbdmap::store {

struct ScanReport {
  int64_t valid_end = 0;  ///< the file should end here (after the last record that is complete)
  int64_t truncated_bytes = 0;
  int corrupt_records = 0;
  std::vector<std::string> problems;
};

/// Called for each record whose header and payload verify; a failure counts the record as corrupt.
using RecordVisitor = std::function<Status(int64_t offset, const uint8_t* payload, size_t size)>;

/// Reads the first `size` bytes of a log of `expected` records. Fails only on an I/O error.
Result<ScanReport> scanLog(int fd, int64_t size, RecordType expected, const std::string& path,
                           const RecordVisitor& visit);

/// Offset of the first position >= from where a record header verifies, or -1 if there is none.
Result<int64_t> findNextHeader(int fd, int64_t from, int64_t size, const std::string& path);

}  // namespace rgbdmap::store
