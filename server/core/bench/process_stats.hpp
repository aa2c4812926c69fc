#pragma once
// What the benches read of their own process: CPU of each thread by name (/proc/self/task), RSS and its peak
// (/proc/self/status), the heap in use (mallinfo2).
#include <map>
#include <string>

namespace rgbdmap::bench {

/// CPU seconds of each of this process's threads, summed by thread name ("rgbdmap-*", the others "other").
std::map<std::string, double> threadCpuByName();
/// A field of /proc/self/status in MB ("VmRSS:" now, "VmHWM:" the peak so far).
double statusMb(const char* field);
inline double rssMb() { return statusMb("VmRSS:"); }
/// Bytes the process's heap has handed out and not freed (every malloc arena and mmapped chunks): RSS
/// minus this is freed memory the allocator keeps, code, stacks and the rendering's textures.
double heapInUseMb();

}  // namespace rgbdmap::bench
