#include "rgbdmap/intake/keyframe_answers.hpp"

namespace rgbdmap {

void KeyframeAnswers::remember(const std::string& robot, int64_t session, int keyframe_id, bool accepted,
                               const std::string& reason, Clock::time_point now) {
  if (options_.per_robot == 0 || options_.total == 0) return;
  std::lock_guard<std::mutex> lock(mutex_);
  Answers& answers = robots_[robot];
  if (Answer* known = findLocked(answers, session, keyframe_id)) {
    known->last_sent = now;
    return;
  }
  Answer answer;
  answer.session = session;
  answer.ack.robot_id = robot;
  answer.ack.keyframe_id = keyframe_id;
  answer.ack.accepted = accepted;
  answer.ack.reason = reason.substr(0, msg::kMaxTextLength);
  answer.last_sent = now;
  answers.push_back(std::move(answer));
  ++total_;
  if (answers.size() > options_.per_robot) {
    answers.pop_front();
    --total_;
  }
  while (total_ > options_.total) forgetOldestLocked();
}

std::optional<msg::KeyframeAck> KeyframeAnswers::repeat(const std::string& robot, int64_t session,
                                                        int keyframe_id, Clock::time_point now) {
  std::lock_guard<std::mutex> lock(mutex_);
  auto it = robots_.find(robot);
  if (it == robots_.end()) return std::nullopt;
  Answer* answer = findLocked(it->second, session, keyframe_id);
  if (!answer || now - answer->last_sent < std::chrono::duration<double>(options_.repeat_interval_s))
    return std::nullopt;
  answer->last_sent = now;
  ++repeated_;
  return answer->ack;
}

KeyframeAnswers::Answer* KeyframeAnswers::findLocked(Answers& answers, int64_t session, int keyframe_id) {
  for (auto it = answers.rbegin(); it != answers.rend(); ++it)  // the newest are asked for most
    if (it->session == session && it->ack.keyframe_id == keyframe_id) return &*it;
  return nullptr;
}

void KeyframeAnswers::forgetOldestLocked() {
  auto most = robots_.end();
  for (auto it = robots_.begin(); it != robots_.end(); ++it)
    if (most == robots_.end() || it->second.size() > most->second.size()) most = it;
  if (most == robots_.end() || most->second.empty()) return;
  most->second.pop_front();
  --total_;
  if (most->second.empty()) robots_.erase(most);
}

uint64_t KeyframeAnswers::repeated() const {
  std::lock_guard<std::mutex> lock(mutex_);
  return repeated_;
}

size_t KeyframeAnswers::size() const {
  std::lock_guard<std::mutex> lock(mutex_);
  return total_;
}

}  // namespace rgbdmap
