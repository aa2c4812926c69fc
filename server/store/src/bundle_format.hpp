#pragma once
// Internal: the map bundle's byte format (server/store/README.md, "Map bundles").
//
//   offset  size  field
//   0       8     magic "RGBDMAPB"
//   8       4     bundle format version (kMapBundleFormatVersion)
//   12      ...   entries, each: kind (u16), 0 (u16), payload length (u32), CRC-32 of the payload (u32),
//                 payload; the first is the manifest, the last the end entry
//   size-32 32    SHA-256 of every byte before it
// All integers little-endian. A bundle is read twice: the SHA-256 first, then the entries one at a time.
#include <cstdint>
#include <cstdio>
#include <memory>
#include <string>

#include "rgbdmap/common/result.hpp"
#include "rgbdmap/proto/messages.hpp"

namespace rgbdmap::store {

enum class BundleEntry : uint16_t { kManifest = 1, kFile = 2, kKeyframe = 3, kLoop = 4, kEnd = 15 };

constexpr size_t kBundleHeaderSize = 12, kBundleEntryHeaderSize = 12, kBundleDigestSize = 32;
constexpr uint32_t kMaxBundleEntryBytes = 1u << 30;  ///< an octree file may be large; keyframes are < 128 MiB

/// Streams a bundle to a temporary file beside `path`; finish() writes the digest, syncs and renames it.
/// Destroyed unfinished: the temporary file is removed.
class BundleWriter {
 public:
  static Result<std::unique_ptr<BundleWriter>> create(const std::string& path);
  ~BundleWriter();
  BundleWriter(const BundleWriter&) = delete;
  BundleWriter& operator=(const BundleWriter&) = delete;

  Status add(BundleEntry kind, const msg::Bytes& payload);
  Result<int64_t> finish();  ///< the bundle's size in bytes

 private:
  struct State;
  explicit BundleWriter(std::unique_ptr<State> state);
  Status write(const uint8_t* data, size_t size);
  std::unique_ptr<State> state_;
};

/// Reads a bundle whose digest verify() checked, entry by entry.
class BundleReader {
 public:
  /// Opens `path` and checks its magic, version and SHA-256.
  static Result<std::unique_ptr<BundleReader>> open(const std::string& path);
  ~BundleReader();
  BundleReader(const BundleReader&) = delete;
  BundleReader& operator=(const BundleReader&) = delete;

  /// The next entry (kind and payload, CRC-checked); an error at the end of the entries or on damage.
  Status next(BundleEntry* kind, msg::Bytes* payload);
  bool atEnd() const;  ///< every entry read (the digest is next)
  int64_t size() const;

 private:
  struct State;
  explicit BundleReader(std::unique_ptr<State> state);
  std::unique_ptr<State> state_;
};

/// A file entry's payload: name length (u16), name, bytes.
msg::Bytes fileEntry(const std::string& name, const std::string& bytes);
Status parseFileEntry(const msg::Bytes& payload, std::string* name, std::string* bytes);

}  // namespace rgbdmap::store
