#include "bundle_format.hpp"

#include <fcntl.h>
#include <openssl/evp.h>
#include <unistd.h>

#include <cstring>

#include "rgbdmap/common/atomic_file.hpp"
#include "rgbdmap/store/map_bundle.hpp"
#include "store_codec.hpp"
#include "store_files.hpp"

namespace rgbdmap::store {
namespace {

constexpr uint8_t kBundleMagic[8] = {'R', 'G', 'B', 'D', 'M', 'A', 'P', 'B'};

struct DigestDeleter {
  void operator()(EVP_MD_CTX* ctx) const { EVP_MD_CTX_free(ctx); }
};
using Digest = std::unique_ptr<EVP_MD_CTX, DigestDeleter>;

Digest newDigest() {
  Digest d(EVP_MD_CTX_new());
  if (d && EVP_DigestInit_ex(d.get(), EVP_sha256(), nullptr) != 1) d.reset();
  return d;
}

}  // namespace

struct BundleWriter::State {
  std::string path, tmp;
  UniqueFd fd;
  Digest digest;
  int64_t offset = 0;
  bool finished = false;
};

BundleWriter::BundleWriter(std::unique_ptr<State> state) : state_(std::move(state)) {}

BundleWriter::~BundleWriter() {
  if (!state_->finished) ::unlink(state_->tmp.c_str());
}

Result<std::unique_ptr<BundleWriter>> BundleWriter::create(const std::string& path) {
  using R = Result<std::unique_ptr<BundleWriter>>;
  auto state = std::make_unique<State>();
  state->path = path;
  state->tmp = path + ".tmp-" + std::to_string(::getpid());
  state->fd = UniqueFd(::open(state->tmp.c_str(), O_WRONLY | O_CREAT | O_TRUNC | O_CLOEXEC, 0644));
  if (state->fd.get() < 0) return R::failure(systemError("cannot create", state->tmp));
  state->digest = newDigest();
  std::unique_ptr<BundleWriter> writer(new BundleWriter(std::move(state)));
  if (!writer->state_->digest) return R::failure("SHA-256 is not available (OpenSSL)");
  uint8_t header[kBundleHeaderSize];
  std::memcpy(header, kBundleMagic, 8);
  putLE(header + 8, kMapBundleFormatVersion, 4);
  if (Status s = writer->write(header, sizeof(header)); !s) return R::failure(s.error());
  return R(std::move(writer));
}

Status BundleWriter::write(const uint8_t* data, size_t size) {
  if (Status s = writeAt(state_->fd.get(), data, size, state_->offset, state_->tmp); !s) return s;
  state_->offset += static_cast<int64_t>(size);
  if (EVP_DigestUpdate(state_->digest.get(), data, size) != 1) return Status::failure("SHA-256 failed");
  return Status::success();
}

Status BundleWriter::add(BundleEntry kind, const msg::Bytes& payload) {
  if (payload.size() > kMaxBundleEntryBytes)
    return Status::failure("a bundle entry of " + std::to_string(payload.size()) + " bytes is too large");
  uint8_t header[kBundleEntryHeaderSize];
  putLE(header, static_cast<uint16_t>(kind), 2);
  putLE(header + 2, 0, 2);
  putLE(header + 4, payload.size(), 4);
  putLE(header + 8, crc32Of(payload.data(), payload.size()), 4);
  if (Status s = write(header, sizeof(header)); !s) return s;
  return write(payload.data(), payload.size());
}

Result<int64_t> BundleWriter::finish() {
  uint8_t digest[EVP_MAX_MD_SIZE];
  unsigned int length = 0;
  if (EVP_DigestFinal_ex(state_->digest.get(), digest, &length) != 1 || length != kBundleDigestSize)
    return Result<int64_t>::failure("SHA-256 failed");
  if (Status s = writeAt(state_->fd.get(), digest, length, state_->offset, state_->tmp); !s)
    return Result<int64_t>::failure(s.error());
  if (::fsync(state_->fd.get()) != 0)
    return Result<int64_t>::failure(systemError("cannot fsync", state_->tmp));
  if (::rename(state_->tmp.c_str(), state_->path.c_str()) != 0)
    return Result<int64_t>::failure(systemError("cannot rename to '" + state_->path + "'", state_->tmp));
  state_->finished = true;
  if (Status s = syncFolder(folderOf(state_->path)); !s) return Result<int64_t>::failure(s.error());
  return state_->offset + static_cast<int64_t>(length);
}

struct BundleReader::State {
  std::string path;
  UniqueFd fd;
  int64_t size = 0, offset = kBundleHeaderSize;
};

BundleReader::BundleReader(std::unique_ptr<State> state) : state_(std::move(state)) {}
BundleReader::~BundleReader() = default;

Result<std::unique_ptr<BundleReader>> BundleReader::open(const std::string& path) {
  using R = Result<std::unique_ptr<BundleReader>>;
  auto state = std::make_unique<State>();
  state->path = path;
  state->fd = UniqueFd(::open(path.c_str(), O_RDONLY | O_CLOEXEC));
  if (state->fd.get() < 0) return R::failure(systemError("cannot open", path));
  Result<int64_t> size = fileSize(state->fd.get(), path);
  if (!size) return R::failure(size.error());
  state->size = *size;
  const std::string what = "'" + path + "' ";
  if (state->size < static_cast<int64_t>(kBundleHeaderSize + kBundleDigestSize))
    return R::failure(what + "is not an rgbdmap map bundle (" + std::to_string(state->size) + " bytes)");
  uint8_t header[kBundleHeaderSize];
  if (Status s = readAt(state->fd.get(), header, sizeof(header), 0, path); !s) return R::failure(s.error());
  if (std::memcmp(header, kBundleMagic, 8) != 0) return R::failure(what + "is not an rgbdmap map bundle");
  if (const uint32_t version = ByteReader(header + 8).u32(); version != kMapBundleFormatVersion)
    return R::failure(what + "is a map bundle of format version " + std::to_string(version) +
                      "; this build reads version " + std::to_string(kMapBundleFormatVersion) + " only");
  Digest digest = newDigest();
  if (!digest) return R::failure("SHA-256 is not available (OpenSSL)");
  const int64_t body = state->size - static_cast<int64_t>(kBundleDigestSize);
  std::vector<uint8_t> buffer(1 << 20);
  for (int64_t at = 0; at < body;) {
    const size_t n = static_cast<size_t>(std::min<int64_t>(body - at, static_cast<int64_t>(buffer.size())));
    if (Status s = readAt(state->fd.get(), buffer.data(), n, at, path); !s) return R::failure(s.error());
    if (EVP_DigestUpdate(digest.get(), buffer.data(), n) != 1) return R::failure("SHA-256 failed");
    at += static_cast<int64_t>(n);
  }
  uint8_t computed[EVP_MAX_MD_SIZE], stored[kBundleDigestSize];
  unsigned int length = 0;
  if (EVP_DigestFinal_ex(digest.get(), computed, &length) != 1 || length != kBundleDigestSize)
    return R::failure("SHA-256 failed");
  if (Status s = readAt(state->fd.get(), stored, sizeof(stored), body, path); !s)
    return R::failure(s.error());
  if (std::memcmp(computed, stored, kBundleDigestSize) != 0)
    return R::failure(what + "is damaged: its SHA-256 does not match its content (truncated or altered)");
  return R(std::unique_ptr<BundleReader>(new BundleReader(std::move(state))));
}

bool BundleReader::atEnd() const {
  return state_->offset >= state_->size - static_cast<int64_t>(kBundleDigestSize);
}

int64_t BundleReader::size() const { return state_->size; }

Status BundleReader::next(BundleEntry* kind, msg::Bytes* payload) {
  const std::string where = "'" + state_->path + "' at byte " + std::to_string(state_->offset) + ": ";
  const int64_t body_end = state_->size - static_cast<int64_t>(kBundleDigestSize);
  if (state_->offset + static_cast<int64_t>(kBundleEntryHeaderSize) > body_end)
    return Status::failure(where + "no entry left (the end entry is missing)");
  uint8_t header[kBundleEntryHeaderSize];
  if (Status s = readAt(state_->fd.get(), header, sizeof(header), state_->offset, state_->path); !s) return s;
  ByteReader fields(header);
  const auto kind_value = fields.u16();
  fields.u16();  // 0
  const uint32_t length = fields.u32(), crc = fields.u32();
  if (length > kMaxBundleEntryBytes ||
      state_->offset + static_cast<int64_t>(kBundleEntryHeaderSize) + length > body_end)
    return Status::failure(where + "an entry of " + std::to_string(length) + " bytes does not fit the file");
  payload->resize(length);
  if (Status s = readAt(state_->fd.get(), payload->data(), length,
                        state_->offset + static_cast<int64_t>(kBundleEntryHeaderSize), state_->path);
      !s)
    return s;
  if (crc32Of(payload->data(), payload->size()) != crc)
    return Status::failure(where + "an entry's CRC does not match");
  *kind = static_cast<BundleEntry>(kind_value);
  state_->offset += static_cast<int64_t>(kBundleEntryHeaderSize) + length;
  return Status::success();
}

msg::Bytes fileEntry(const std::string& name, const std::string& bytes) {
  msg::Bytes out(2 + name.size() + bytes.size());
  putLE(out.data(), name.size(), 2);
  std::memcpy(out.data() + 2, name.data(), name.size());
  if (!bytes.empty()) std::memcpy(out.data() + 2 + name.size(), bytes.data(), bytes.size());
  return out;
}

Status parseFileEntry(const msg::Bytes& payload, std::string* name, std::string* bytes) {
  if (payload.size() < 2) return Status::failure("a file entry without a name");
  const size_t n = ByteReader(payload.data()).u16();
  if (n == 0 || 2 + n > payload.size()) return Status::failure("a file entry with a bad name length");
  name->assign(reinterpret_cast<const char*>(payload.data() + 2), n);
  bytes->assign(reinterpret_cast<const char*>(payload.data() + 2 + n), payload.size() - 2 - n);
  return Status::success();
}

}  // namespace rgbdmap::store
