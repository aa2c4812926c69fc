#include "log_scan.hpp"

#include <algorithm>

#include "store_files.hpp"

namespace rgbdmap::store {
namespace {

std::string at(int64_t offset) { return "offset " + std::to_string(offset); }

/// Handles a header that does not verify at `pos`: skips to the next record, or cuts the rest off when no
/// record follows. Returns the offset to continue at, or -1 when the scan ends.
Result<int64_t> skipDamaged(int fd, int64_t pos, int64_t size, const std::string& path, ScanReport* report) {
  Result<int64_t> next = findNextHeader(fd, pos + 1, size, path);
  if (!next) return next;
  ++report->corrupt_records;
  if (*next < 0) {
    report->truncated_bytes += size - pos;
    report->problems.push_back(path + ": damaged record header at " + at(pos) + " and no record after it; " +
                               std::to_string(size - pos) + " bytes cut off");
    return int64_t{-1};
  }
  report->problems.push_back(path + ": damaged record header at " + at(pos) + "; skipped " +
                             std::to_string(*next - pos) + " bytes to the next record");
  return next;
}

}  // namespace

Result<int64_t> findNextHeader(int fd, int64_t from, int64_t size, const std::string& path) {
  constexpr int64_t kChunk = 1 << 20;
  constexpr int64_t kHeader = static_cast<int64_t>(kRecordHeaderSize);
  Bytes chunk;
  for (int64_t start = from; start + kHeader <= size;) {
    const int64_t n = std::min(kChunk, size - start);
    chunk.resize(static_cast<size_t>(n));
    if (Status s = readAt(fd, chunk.data(), chunk.size(), start, path); !s)
      return Result<int64_t>::failure(s.error());
    for (int64_t i = 0; i + kHeader <= n; ++i)
      if (chunk[i] == kRecordMagic[0] && parseRecordHeader(chunk.data() + i)) return start + i;
    if (start + n >= size) break;
    start += n - (kHeader - 1);  // overlap: a header across the chunk boundary is seen next time
  }
  return int64_t{-1};
}

Result<ScanReport> scanLog(int fd, int64_t size, RecordType expected, const std::string& path,
                           const RecordVisitor& visit) {
  ScanReport report;
  Bytes payload;
  int64_t pos = 0;
  while (pos < size) {
    const int64_t remaining = size - pos;
    if (remaining < static_cast<int64_t>(kRecordHeaderSize)) {
      report.truncated_bytes += remaining;
      report.problems.push_back(path + ": incomplete record header at " + at(pos) + " (" +
                                std::to_string(remaining) + " bytes) cut off");
      break;
    }
    uint8_t head[kRecordHeaderSize];
    if (Status s = readAt(fd, head, sizeof head, pos, path); !s)
      return Result<ScanReport>::failure(s.error());
    const std::optional<RecordHeader> header = parseRecordHeader(head);
    if (!header) {
      Result<int64_t> next = skipDamaged(fd, pos, size, path, &report);
      if (!next) return Result<ScanReport>::failure(next.error());
      if (*next < 0) break;
      pos = *next;
      continue;
    }
    const int64_t total = static_cast<int64_t>(kRecordHeaderSize) + header->payload_size;
    if (total > remaining) {
      report.truncated_bytes += remaining;
      report.problems.push_back(path + ": incomplete record at " + at(pos) + " (" +
                                std::to_string(remaining) + " of " + std::to_string(total) +
                                " bytes) cut off");
      break;
    }
    payload.resize(header->payload_size);
    if (Status s = readAt(fd, payload.data(), payload.size(), pos + kRecordHeaderSize, path); !s)
      return Result<ScanReport>::failure(s.error());
    Status ok = verifyRecord(*header, expected, payload.data());
    if (ok) ok = visit(pos, payload.data(), payload.size());
    if (!ok) {
      ++report.corrupt_records;
      report.problems.push_back(path + ": record at " + at(pos) + " (" + std::to_string(total) +
                                " bytes) skipped: " + ok.error());
    }
    pos += total;
  }
  report.valid_end = std::min(pos, size);
  return report;
}

}  // namespace rgbdmap::store
