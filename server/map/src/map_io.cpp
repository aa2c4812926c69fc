// Binary (.bt) and full (.ot) octree bytes; untrusted input is checked before OctoMap parses it.
#include "rgbdmap/map/map_io.hpp"

#include <cmath>
#include <cstring>
#include <fstream>
#include <iterator>
#include <sstream>
#include <string_view>

#include <octomap/OcTree.h>

#include "rgbdmap/common/atomic_file.hpp"
#include "rgbdmap/proto/messages.hpp"

namespace rgbdmap {
namespace {

constexpr const char* kBinaryHeader = "# Octomap OcTree binary file";
constexpr const char* kFullHeader = "# Octomap OcTree file";
constexpr int kTreeDepth = 16;
constexpr size_t kMaxNodes = size_t{1} << 26;  // far above any map we send (64 MB / 2 bytes per node)

struct Header {
  bool binary = false;
  std::string id;
  size_t size = 0;
  double res = 0.0;
  size_t data_offset = 0;
};

/// Parses the text header (first line, then `id`, `size`, `res` lines, comments, up to `data`).
Result<Header> parseHeader(const std::vector<uint8_t>& bytes) {
  Header h;
  size_t pos = 0;
  bool first = true, have_size = false, have_res = false;
  for (int line_no = 0; line_no < 64; ++line_no) {
    size_t end = pos;
    while (end < bytes.size() && end - pos < 256 && bytes[end] != '\n') ++end;
    if (end >= bytes.size() || bytes[end] != '\n')
      return Result<Header>::failure("truncated or malformed header");
    const std::string line(bytes.begin() + static_cast<long>(pos), bytes.begin() + static_cast<long>(end));
    pos = end + 1;
    if (first) {
      if (line.rfind(kBinaryHeader, 0) == 0)
        h.binary = true;
      else if (line.rfind(kFullHeader, 0) != 0)
        return Result<Header>::failure("not an OctoMap file (first line '" + line.substr(0, 40) + "')");
      first = false;
      continue;
    }
    if (line.empty() || line[0] == '#') continue;
    std::istringstream in(line);
    std::string token;
    in >> token;
    if (token == "data") {
      if (h.id.empty() || !have_size || !have_res)
        return Result<Header>::failure("header lacks id, size or res");
      h.data_offset = pos;
      return h;
    }
    if (token == "id") {
      in >> h.id;
    } else if (token == "size") {
      long long n = -1;
      have_size = static_cast<bool>(in >> n) && n >= 0 && static_cast<size_t>(n) <= kMaxNodes;
      h.size = have_size ? static_cast<size_t>(n) : 0;
      if (!have_size) return Result<Header>::failure("bad size in header");
    } else if (token == "res") {
      have_res = static_cast<bool>(in >> h.res) && std::isfinite(h.res) && h.res >= 1e-4 && h.res <= 100.0;
      if (!have_res) return Result<Header>::failure("bad resolution in header");
    } else {
      return Result<Header>::failure("unknown header line '" + line.substr(0, 40) + "'");
    }
  }
  return Result<Header>::failure("header too long");
}

/// Walks binary-format nodes: 2 bytes per inner node, 2 bits per child (1 free, 2 occupied, 3 inner).
bool walkBinary(const std::vector<uint8_t>& b, size_t* pos, int depth, size_t* nodes) {
  if (*pos + 2 > b.size()) return false;
  const unsigned bits = b[*pos] | (unsigned(b[*pos + 1]) << 8);
  *pos += 2;
  for (int i = 0; i < 8; ++i) {
    const unsigned code = (bits >> (2 * i)) & 3u;
    if (code == 0) continue;
    if (++*nodes > kMaxNodes) return false;
    if (code == 3 && (depth + 1 >= kTreeDepth || !walkBinary(b, pos, depth + 1, nodes))) return false;
  }
  return true;
}

/// Walks full-format nodes of an OcTree: float log-odds, one byte of child flags, children in order.
bool walkFull(const std::vector<uint8_t>& b, size_t* pos, int depth, size_t* nodes) {
  if (*pos + 5 > b.size()) return false;
  float value;
  std::memcpy(&value, &b[*pos], sizeof value);
  if (!std::isfinite(value)) return false;
  const unsigned children = b[*pos + 4];
  *pos += 5;
  if (children && depth >= kTreeDepth) return false;
  for (int i = 0; i < 8; ++i)
    if ((children >> i) & 1u) {
      if (++*nodes > kMaxNodes || !walkFull(b, pos, depth + 1, nodes)) return false;
    }
  return true;
}

std::string streamText(const std::vector<uint8_t>& bytes) { return std::string(bytes.begin(), bytes.end()); }

}  // namespace

Result<std::vector<uint8_t>> serializeTree(const octomap::OcTree& tree) {
  // The header OctoMap's writeBinaryConst() writes, without its progress output on stderr.
  std::ostringstream out(std::ios::binary);
  out.precision(17);
  out << kBinaryHeader << "\n# written by rgbdmap\nid " << tree.getTreeType() << "\nsize " << tree.size()
      << "\nres " << tree.getResolution() << "\ndata\n";
  if (!tree.writeBinaryData(out)) return Result<std::vector<uint8_t>>::failure("writing the octree failed");
  const std::string s = out.str();
  if (s.size() > static_cast<size_t>(msg::kMaxMapBytes))
    return Result<std::vector<uint8_t>>::failure("octree is " + std::to_string(s.size()) +
                                                 " bytes, over the " + std::to_string(msg::kMaxMapBytes) +
                                                 "-byte limit");
  return std::vector<uint8_t>(s.begin(), s.end());
}

Result<std::unique_ptr<octomap::OcTree>> deserializeTree(const std::vector<uint8_t>& bytes) {
  using R = Result<std::unique_ptr<octomap::OcTree>>;
  if (bytes.size() > static_cast<size_t>(msg::kMaxMapBytes) * 2) return R::failure("octree bytes too large");
  const Result<Header> h = parseHeader(bytes);
  if (!h) return R::failure("octree header: " + h.error());
  if (h->id != "OcTree") return R::failure("unsupported tree type '" + h->id + "' (expected OcTree)");
  size_t pos = h->data_offset, nodes = 0;
  if (h->size > 0) {
    nodes = 1;
    const bool ok = h->binary ? walkBinary(bytes, &pos, 0, &nodes) : walkFull(bytes, &pos, 0, &nodes);
    if (!ok) return R::failure("octree data truncated or corrupt");
  }
  if (pos != bytes.size())
    return R::failure("octree data has " + std::to_string(bytes.size() - pos) + " trailing bytes");
  if (nodes != h->size)
    return R::failure("octree node count " + std::to_string(nodes) + " != header size " +
                      std::to_string(h->size));
  auto tree = std::make_unique<octomap::OcTree>(h->res);
  if (h->size == 0) return R(std::move(tree));
  std::istringstream in(streamText(bytes), std::ios::binary);
  in.seekg(static_cast<std::streamoff>(h->data_offset));
  if (h->binary)
    tree->readBinaryData(in);
  else
    tree->readData(in);
  if (!in) return R::failure("octree data could not be read");
  return R(std::move(tree));
}

Status writeMapFiles(const octomap::OcTree& tree, const std::string& bt_path, const std::string& ot_path) {
  // Serialised in memory first, then written atomically: a failed write (a full disk) leaves the previous
  // file whole, never a truncated one in its place.
  if (!bt_path.empty()) {
    const Result<std::vector<uint8_t>> bytes = serializeTree(tree);
    if (!bytes) return Status::failure(bt_path + ": " + bytes.error());
    const std::string_view view(reinterpret_cast<const char*>(bytes->data()), bytes->size());
    if (const Status s = writeFileAtomic(bt_path, view); !s) return s;
  }
  if (!ot_path.empty()) {
    std::ostringstream out(std::ios::binary);
    if (!tree.write(out)) return Status::failure(ot_path + ": writing the octree failed");
    if (const Status s = writeFileAtomic(ot_path, out.str()); !s) return s;
  }
  return Status::success();
}

Result<std::unique_ptr<octomap::OcTree>> readMapFile(const std::string& path) {
  using R = Result<std::unique_ptr<octomap::OcTree>>;
  std::ifstream in(path, std::ios::binary);
  if (!in) return R::failure(path + ": cannot open");
  in.seekg(0, std::ios::end);
  const std::streamoff size = in.tellg();
  if (size < 0 || size > static_cast<std::streamoff>(msg::kMaxMapBytes) * 2)
    return R::failure(path + ": unreadable or too large");
  in.seekg(0);
  std::vector<uint8_t> bytes(static_cast<size_t>(size));
  if (size > 0 && !in.read(reinterpret_cast<char*>(bytes.data()), size))
    return R::failure(path + ": read error");
  R tree = deserializeTree(bytes);
  if (!tree) return R::failure(path + ": " + tree.error());
  return tree;
}

}  // namespace rgbdmap
