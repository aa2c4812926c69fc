// A ROS 2 subscriber for the tests, as a ROS 2 node would subscribe (rt/ topics, the ROS 2 DDS type names,
// the QoS it asks for): takes the samples of each TOPIC serialised, as they were on the wire (dds_takecdr),
// and writes the newest one of each into OUT_DIR/<topic with '/' as '_'>.cdr, the CDR bytes with their
// 4-byte encapsulation header. It ends when every topic has had COUNT samples or after TIMEOUT_S.
// Usage: ros2_capture OUT_DIR TIMEOUT_S COUNT TOPIC:TYPE:latched|volatile...
//   TYPE: OccupancyGrid Octomap PointCloud2 TFMessage PoseStamped Path
// Exit 0 when every topic had its samples, 1 otherwise (the missing ones named).
#include <dds/dds.h>
#include <dds/ddsi/ddsi_serdata.h>

#include <chrono>
#include <cstdio>
#include <fstream>
#include <map>
#include <string>
#include <thread>
#include <vector>

#include "rgbdmap/ros2/dds.hpp"

namespace {

const dds_topic_descriptor_t* typeOf(const std::string& name) {
  static const std::map<std::string, const dds_topic_descriptor_t*> types = {
      {"OccupancyGrid", &nav_msgs_msg_dds__OccupancyGrid__desc},
      {"Octomap", &octomap_msgs_msg_dds__Octomap__desc},
      {"PointCloud2", &sensor_msgs_msg_dds__PointCloud2__desc},
      {"TFMessage", &tf2_msgs_msg_dds__TFMessage__desc},
      {"PoseStamped", &geometry_msgs_msg_dds__PoseStamped__desc},
      {"Path", &nav_msgs_msg_dds__Path__desc}};
  const auto it = types.find(name);
  return it == types.end() ? nullptr : it->second;
}

struct Topic {
  std::string name, file;
  dds_entity_t reader = 0;
  int samples = 0;
};

}  // namespace

int main(int argc, char** argv) {
  if (argc < 5)
    return std::fprintf(stderr, "usage: ros2_capture OUT_DIR TIMEOUT_S COUNT TOPIC:TYPE:QOS...\n"), 2;
  const std::string out = argv[1];
  const double timeout_s = std::atof(argv[2]);
  const int count = std::atoi(argv[3]);
  if (const rgbdmap::Status s = rgbdmap::ros2::checkDdsConfiguration(); !s)
    return std::fprintf(stderr, "%s\n", s.error().c_str()), 2;
  const dds_entity_t participant = dds_create_participant(0, nullptr, nullptr);
  if (participant < 0) return std::fprintf(stderr, "no DDS participant\n"), 1;
  std::vector<Topic> topics;
  for (int i = 4; i < argc; ++i) {
    const std::string spec = argv[i];
    const size_t a = spec.find(':'), b = spec.rfind(':');
    const dds_topic_descriptor_t* type = a == b ? nullptr : typeOf(spec.substr(a + 1, b - a - 1));
    if (!type) return std::fprintf(stderr, "bad topic spec '%s'\n", spec.c_str()), 2;
    Topic t;
    t.name = spec.substr(0, a);
    std::string base = t.name.substr(t.name.rfind('/', 0) == 0 ? 1 : 0);
    for (char& c : base) c = c == '/' ? '_' : c;
    t.file = out + "/" + base + ".cdr";
    dds_qos_t* qos = dds_create_qos();
    dds_qset_reliability(qos, DDS_RELIABILITY_RELIABLE, DDS_SECS(1));
    const bool latched = spec.substr(b + 1) == "latched";
    dds_qset_durability(qos, latched ? DDS_DURABILITY_TRANSIENT_LOCAL : DDS_DURABILITY_VOLATILE);
    dds_qset_history(qos, DDS_HISTORY_KEEP_LAST, latched ? 1 : 100);
    const dds_entity_t topic =
        dds_create_topic(participant, type, rgbdmap::ros2::ddsTopicName(t.name).c_str(), nullptr, nullptr);
    t.reader = topic < 0 ? topic : dds_create_reader(participant, topic, qos, nullptr);
    dds_delete_qos(qos);
    if (t.reader < 0) return std::fprintf(stderr, "no reader for %s\n", t.name.c_str()), 1;
    topics.push_back(t);
  }
  const auto start = std::chrono::steady_clock::now();
  auto done = [&] {
    for (const Topic& t : topics)
      if (t.samples < count) return false;
    return true;
  };
  while (!done() &&
         std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count() < timeout_s) {
    for (Topic& t : topics) {
      for (int k = 0; k < 200; ++k) {  // bounded: at most 200 samples a topic a round
        struct ddsi_serdata* data = nullptr;
        dds_sample_info_t info;
        if (dds_takecdr(t.reader, &data, 1, &info, DDS_ANY_STATE) != 1) break;
        std::vector<char> bytes(ddsi_serdata_size(data));
        ddsi_serdata_to_ser(data, 0, bytes.size(), bytes.data());
        ddsi_serdata_unref(data);
        if (!info.valid_data) continue;
        std::ofstream(t.file, std::ios::binary | std::ios::trunc)
            .write(bytes.data(), static_cast<std::streamsize>(bytes.size()));
        ++t.samples;
      }
    }
    std::this_thread::sleep_for(std::chrono::milliseconds(20));
  }
  int missing = 0;
  for (const Topic& t : topics) {
    std::printf("%s %s: %d samples\n", t.samples >= count ? "ok:" : "FAIL:", t.name.c_str(), t.samples);
    missing += t.samples < count;
  }
  dds_delete(participant);
  return missing == 0 ? 0 : 1;
}
