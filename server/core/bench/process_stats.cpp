#include "process_stats.hpp"

#include <dirent.h>
#include <malloc.h>
#include <unistd.h>

#include <cstdlib>
#include <cstring>
#include <fstream>
#include <sstream>

namespace rgbdmap::bench {

std::map<std::string, double> threadCpuByName() {
  std::map<std::string, double> cpu;
  const double tick = static_cast<double>(sysconf(_SC_CLK_TCK));
  DIR* dir = opendir("/proc/self/task");
  if (!dir) return cpu;
  while (dirent* e = readdir(dir)) {
    if (e->d_name[0] == '.') continue;
    const std::string base = std::string("/proc/self/task/") + e->d_name;
    std::ifstream comm(base + "/comm"), stat(base + "/stat");
    std::string name, line;
    if (!std::getline(comm, name) || !std::getline(stat, line)) continue;
    const size_t close = line.rfind(')');  // the name in stat may hold spaces
    if (close == std::string::npos) continue;
    std::istringstream fields(line.substr(close + 2));
    std::string f;
    double utime = 0.0, stime = 0.0;
    for (int k = 3; k <= 15 && fields >> f; ++k) {  // field 3 is the state; 14 utime, 15 stime
      if (k == 14) utime = std::atof(f.c_str());
      if (k == 15) stime = std::atof(f.c_str());
    }
    cpu[name.rfind("rgbdmap-", 0) == 0 ? name : "other"] += (utime + stime) / tick;
  }
  closedir(dir);
  return cpu;
}

double statusMb(const char* field) {
  std::ifstream status("/proc/self/status");
  std::string line;
  const size_t n = std::strlen(field);
  while (std::getline(status, line))
    if (line.compare(0, n, field) == 0) return std::atof(line.c_str() + n) / 1024.0;
  return 0.0;
}

double heapInUseMb() {
  const struct mallinfo2 m = mallinfo2();
  return static_cast<double>(m.uordblks + m.hblkhd) / (1024.0 * 1024.0);
}

}  // namespace rgbdmap::bench
