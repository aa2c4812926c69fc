#include "rgbdmap/ros2/dds.hpp"

#include <cctype>
#include <cstdlib>

namespace rgbdmap::ros2 {

Status checkDdsConfiguration() {
  const char* uri = std::getenv("CYCLONEDDS_URI");
  if (uri == nullptr || *uri == '\0')
    return Status::failure(
        "CYCLONEDDS_URI is not set; point it at deploy/dds/cyclonedds-*.xml (Cyclone's "
        "built-in default multicasts on every interface)");
  return Status::success();
}

std::string ddsError(const char* what, dds_return_t rc) {
  return std::string(what) + ": " + dds_strretcode(rc);
}

std::string ddsTopicName(const std::string& ros_name) {
  return "rt/" + (ros_name.rfind('/', 0) == 0 ? ros_name.substr(1) : ros_name);
}

Result<dds_entity_t> createWriter(dds_entity_t participant, const dds_topic_descriptor_t* type,
                                  const std::string& ros_name, const Qos& qos) {
  const dds_entity_t topic =
      dds_create_topic(participant, type, ddsTopicName(ros_name).c_str(), nullptr, nullptr);
  if (topic < 0) return Result<dds_entity_t>::failure(ddsError(("topic " + ros_name).c_str(), topic));
  dds_qos_t* q = dds_create_qos();
  dds_qset_reliability(q, qos.reliable ? DDS_RELIABILITY_RELIABLE : DDS_RELIABILITY_BEST_EFFORT, DDS_SECS(1));
  dds_qset_durability(q, qos.transient_local ? DDS_DURABILITY_TRANSIENT_LOCAL : DDS_DURABILITY_VOLATILE);
  dds_qset_history(q, DDS_HISTORY_KEEP_LAST, qos.depth);
  const dds_entity_t writer = dds_create_writer(participant, topic, q, nullptr);
  dds_delete_qos(q);
  if (writer < 0) return Result<dds_entity_t>::failure(ddsError(("writer " + ros_name).c_str(), writer));
  return writer;
}

std::string rosNameToken(const std::string& id) {
  std::string out;
  for (const char c : id) out += std::isalnum(static_cast<unsigned char>(c)) || c == '_' ? c : '_';
  if (out.empty() || std::isdigit(static_cast<unsigned char>(out[0]))) out = "_" + out;
  return out;
}

}  // namespace rgbdmap::ros2
