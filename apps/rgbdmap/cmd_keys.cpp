// rgbdmap keys new ROBOT...: a 32-byte HMAC key per robot (DIR/<robot>.key, what robot.key_file names) and
// the server's keys file (DIR/server_keys.txt, "robot_id hexkey" lines, what server.keys_file names). A
// robot that already has a key keeps it (--force: a new one); other robots' lines stay. Files are 0600 in a
// 0700 folder, written atomically.
#include <sys/stat.h>

#include <cerrno>
#include <cstdio>
#include <cstring>
#include <fstream>
#include <map>
#include <sstream>
#include <string>
#include <vector>

#include "commands.hpp"
#include "rgbdmap/cli/cli.hpp"
#include "rgbdmap/common/atomic_file.hpp"
#include "rgbdmap/link/robot_client_config.hpp"
#include "rgbdmap/proto/envelope.hpp"

namespace rgbdmap::cmd {
namespace {

const char* kKeysUsage =
    "usage: rgbdmap keys new ROBOT [ROBOT...] [--dir DIR] [--force]\n"
    "Writes DIR/<ROBOT>.key (the robot's HMAC key: robot.key_file) per robot and adds them to\n"
    "DIR/server_keys.txt (the server's keys file: server.keys_file). A robot with a key keeps it.\n"
    "  --dir DIR   where the keys go (default keys; created 0700, files 0600)\n"
    "  --force     give robots that have a key a new one (their robots must get the new file)\n"
    "exit status: 0 written, 1 a file could not be read or written, 2 usage error\n";

constexpr size_t kKeyBytes = 32;

/// The server keys file's robot -> hex key lines (comments dropped); empty when the file does not exist.
Result<std::map<std::string, std::string>> readServerKeys(const std::string& path) {
  using R = Result<std::map<std::string, std::string>>;
  std::map<std::string, std::string> keys;
  std::ifstream in(path);
  if (!in) return keys;
  if (auto checked = msg::readKeysFile(path); !checked) return R::failure(checked.error());
  std::string line;
  while (std::getline(in, line)) {
    std::istringstream fields(line);
    std::string robot, key;
    if (fields >> robot >> key && robot[0] != '#') keys[robot] = key;
  }
  return keys;
}

}  // namespace

int keys(int argc, char** argv) {
  cli::Args args(argc, argv, {"help", "force"});
  if (args.has("help")) {
    std::fputs(kKeysUsage, stdout);
    return 0;
  }
  args.checkAllowed({"help", "force", "dir"});
  std::vector<std::string> errors(args.errors().begin(), args.errors().end());
  const std::vector<std::string>& words = args.positional();
  if (words.empty() || words[0] != "new") errors.push_back("expected 'new ROBOT [ROBOT...]'");
  const std::vector<std::string> robots(words.empty() ? words.end() : words.begin() + 1, words.end());
  if (!words.empty() && words[0] == "new" && robots.empty()) errors.push_back("name at least one robot");
  for (const std::string& robot : robots)
    if (const Status s = msg::KeyStore().add(robot, msg::Bytes(kKeyBytes, 1)); !s || robot == msg::kServerId)
      errors.push_back("robot '" + robot + "': not a robot id ([A-Za-z0-9_-]{1,32}, not \"server\")");
  if (!errors.empty()) return cli::usageError(errors, kKeysUsage);
  const std::string dir = args.getOr("dir", "keys");
  ::umask(077);  // every file and folder written here: the owner's only, from the start
  if (::mkdir(dir.c_str(), 0700) != 0 && errno != EEXIST)
    return std::fprintf(stderr, "rgbdmap keys: cannot create %s: %s\n", dir.c_str(), std::strerror(errno)), 1;
  const std::string server_path = dir + "/server_keys.txt";
  auto server_keys = readServerKeys(server_path);
  if (!server_keys) return std::fprintf(stderr, "rgbdmap keys: %s\n", server_keys.error().c_str()), 1;
  for (const std::string& robot : robots) {
    const std::string path = dir + "/" + robot + ".key";
    std::string what = "new";
    Result<msg::Bytes> key = Result<msg::Bytes>::failure("");
    if (!args.has("force") && std::ifstream(path)) {
      key = readKeyFile(path);
      if (!key)
        return std::fprintf(stderr, "rgbdmap keys: %s (--force replaces it)\n", key.error().c_str()), 1;
      what = "kept";
    } else {
      key = msg::newKey();
      if (!key) return std::fprintf(stderr, "rgbdmap keys: %s\n", key.error().c_str()), 1;
      if (const Status s = writeFileAtomic(path, msg::toHex(*key) + "\n"); !s)
        return std::fprintf(stderr, "rgbdmap keys: %s\n", s.error().c_str()), 1;
    }
    (*server_keys)[robot] = msg::toHex(*key);
    std::printf("%s: %s (%s)\n", robot.c_str(), path.c_str(), what.c_str());
  }
  std::string text =
      "# robot_id hexkey: the server's keys file (server.keys_file), written by rgbdmap keys\n";
  for (const auto& [robot, key] : *server_keys) text += robot + " " + key + "\n";
  if (const Status s = writeFileAtomic(server_path, text); !s)
    return std::fprintf(stderr, "rgbdmap keys: %s\n", s.error().c_str()), 1;
  std::printf("server keys: %s (%zu robot%s)\n", server_path.c_str(), server_keys->size(),
              server_keys->size() == 1 ? "" : "s");
  return 0;
}

}  // namespace rgbdmap::cmd
