#include "rgbdmap/viewer/map_subscriber.hpp"

#include "rgbdmap/common/logging.hpp"
#include "rgbdmap/proto/channels.hpp"

namespace rgbdmap::viewer {

Status MapSubscriber::setKeys(const msg::KeyStore& server_keys, bool open) {
  for (const std::string& robot : view_.robots()) {
    RobotKeys& r = robots_[robot];
    r.keys = open ? msg::KeyStore::openMode() : msg::KeyStore();
    if (const msg::Bytes* key = server_keys.find(robot)) {
      if (Status s = r.keys.add(msg::kServerId, *key); !s) return s;
      if (Status s = r.keys.add(robot, *key); !s) return s;  // the robot signs its own RobotPose
    } else if (!open) {
      return Status::failure("no key for robot '" + robot + "'");
    }
  }
  return Status::success();
}

Status MapSubscriber::subscribe(transport::Transport& transport) {
  using T = msg::MessageType;
  for (const std::string& robot : view_.robots()) {
    for (const T type : {T::kMapUpdate, T::kPoseCorrections, T::kOccupancySlice, T::kServerStatus,
                         T::kLoopEdges, T::kRobotPose, T::kLinkStatus}) {
      const auto channel = msg::channelFor(type, robot);
      if (!channel) return Status::failure(channel.error());
      auto handler = [this, robot, type](const std::string&, const uint8_t* data, size_t size) {
        onMessage(robot, type, data, size);
      };
      if (Status s = transport.subscribe(*channel, handler); !s) return s;
    }
  }
  return Status::success();
}

void MapSubscriber::onMessage(const std::string& robot, msg::MessageType type, const uint8_t* data,
                              size_t size) {
  if (!enabled_) return;
  view_.countBytes(robot, size);
  std::optional<msg::OpenedEnvelope> opened;
  {
    std::lock_guard<std::mutex> lock(mutex_);
    RobotKeys& r = robots_[robot];
    auto result = msg::openEnvelope(data, size, r.keys, &r.guard, &rejects_);
    if (!result) return;  // counted and logged (rate-limited) by openEnvelope
    opened = std::move(*result);
  }
  // Everything comes from the server, but a robot's live pose and link status, which come from that robot.
  const bool from_robot = type == msg::MessageType::kRobotPose || type == msg::MessageType::kLinkStatus;
  const std::string sender = from_robot ? robot : std::string(msg::kServerId);
  if (opened->header.sender != sender || opened->type != type) {
    rejects_.add(msg::RejectReason::kUnknownSender, "viewer: " + opened->header.sender + " on " + robot);
    return;
  }
  switch (type) {
    case msg::MessageType::kMapUpdate:
      if (auto m = msg::decodeMessage<msg::MapUpdate>(*opened, &rejects_)) {
        if (const Status s = view_.applyMap(robot, *m); !s) {
          ++map_errors_;
          log::warn("viewer: map update for ", robot, ": ", s.error());
        } else {
          ++map_updates_;
        }
      }
      break;
    case msg::MessageType::kPoseCorrections:
      if (auto m = msg::decodeMessage<msg::PoseCorrections>(*opened, &rejects_))
        view_.applyCorrections(robot, *m);
      break;
    case msg::MessageType::kOccupancySlice:
      if (auto m = msg::decodeMessage<msg::OccupancySlice>(*opened, &rejects_))
        view_.applySlice(robot, std::move(*m));
      break;
    case msg::MessageType::kLoopEdges:
      if (auto m = msg::decodeMessage<msg::LoopEdges>(*opened, &rejects_))
        view_.applyLoops(robot, std::move(*m));
      break;
    case msg::MessageType::kServerStatus:
      if (auto m = msg::decodeMessage<msg::ServerStatus>(*opened, &rejects_)) view_.applyStatus(robot, *m);
      break;
    case msg::MessageType::kRobotPose:
      if (auto m = msg::decodeMessage<msg::RobotPose>(*opened, &rejects_)) view_.applyRobotPose(robot, *m);
      break;
    case msg::MessageType::kLinkStatus:
      if (auto m = msg::decodeMessage<msg::LinkStatus>(*opened, &rejects_)) view_.applyLinkStatus(robot, *m);
      break;
    default:
      break;
  }
}

}  // namespace rgbdmap::viewer
