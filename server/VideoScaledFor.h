// Why a session's video stream is sent smaller than its scene (the frame's `video.scaled_for`; PROTOCOL.md, Session
// 11): its link's bitrate, its share of the encoder threads' time, its share of the encoders' memory, or a crowd that
// leaves its frames' drawing smaller than the stream. One list for VideoStream, the server's counters and /metrics'
// labels.
#pragma once

#include <cstddef>
#include <cstdint>
#include <span>

#include "common/EnumNames.h"

namespace voxbrick::server {

enum class VideoScaledFor : uint8_t { None, Link, Encoders, Memory, Drawing };
inline constexpr size_t kVideoScaledForCount = 5;

inline constexpr common::EnumName<VideoScaledFor> kVideoScaledForNames[] = {{VideoScaledFor::None, "none"},
                                                                            {VideoScaledFor::Link, "link"},
                                                                            {VideoScaledFor::Encoders, "encoders"},
                                                                            {VideoScaledFor::Memory, "memory"},
                                                                            {VideoScaledFor::Drawing, "drawing"}};
constexpr std::span<const common::EnumName<VideoScaledFor>> enumNames(VideoScaledFor) { return kVideoScaledForNames; }

}  // namespace voxbrick::server
