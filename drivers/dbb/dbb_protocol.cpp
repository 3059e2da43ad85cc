// The DBB bus protocol (dbb_protocol.hpp): frames classified, and SYNC cycles assembled from the encoders' TPDOs.
#include "drivers/dbb/dbb_protocol.hpp"

#include <cmath>
#include <cstring>
#include <limits>

namespace guideway::drivers::dbb {

std::uint32_t position_to_count(const EncoderScale& scale, double position_m) noexcept {
  const double counts = (position_m - scale.offset_m) / (scale.resolution_m * scale.direction);
  if (!std::isfinite(counts)) return 0;
  const auto rel = static_cast<std::int64_t>(std::llround(counts));
  // Two's complement wrap to 32 bits, as the encoder's counter does.
  return static_cast<std::uint32_t>(static_cast<std::uint64_t>(scale.zero_count + rel) & 0xFFFFFFFFu);
}

double count_to_position(const EncoderScale& scale, std::int64_t unwrapped_count) noexcept {
  return scale.offset_m +
         scale.direction * scale.resolution_m * static_cast<double>(unwrapped_count - scale.zero_count);
}

can_frame make_sync_frame() noexcept {
  can_frame f{};
  f.can_id = sync_cob_id;
  f.can_dlc = 0;
  return f;
}

can_frame make_position_pdo(std::uint8_t node_id, std::uint32_t count) noexcept {
  can_frame f{};
  f.can_id = tpdo1_cob_base + node_id;
  f.can_dlc = 4;
  for (int i = 0; i < 4; ++i) f.data[i] = static_cast<std::uint8_t>(count >> (8 * i));
  return f;
}

FrameInfo classify_frame(const can_frame& frame) noexcept {
  FrameInfo info;
  if (frame.can_id & CAN_ERR_FLAG) {
    info.kind = FrameInfo::Kind::error_frame;
    info.error_class = frame.can_id & CAN_ERR_MASK;
    return info;
  }
  if (frame.can_dlc > CAN_MAX_DLEN) {
    info.kind = FrameInfo::Kind::bad;
    info.why = "DLC greater than 8";
    return info;
  }
  if ((frame.can_id & CAN_EFF_FLAG) || (frame.can_id & CAN_RTR_FLAG)) return info;  // other
  const std::uint32_t id = frame.can_id & CAN_SFF_MASK;
  if (id == sync_cob_id) {
    if (frame.can_dlc > 1) {
      info.kind = FrameInfo::Kind::bad;
      info.why = "SYNC longer than 1 byte";
      return info;
    }
    info.kind = FrameInfo::Kind::sync;
    return info;
  }
  if (id > emcy_cob_base && id < emcy_cob_base + 0x80) {
    info.kind = FrameInfo::Kind::emergency;
    info.node = static_cast<std::uint8_t>(id - emcy_cob_base);
    return info;
  }
  if (id > tpdo1_cob_base && id < tpdo1_cob_base + 0x80) {
    info.node = static_cast<std::uint8_t>(id - tpdo1_cob_base);
    if (frame.can_dlc != 4) {
      info.kind = FrameInfo::Kind::bad;
      info.why = "TPDO1 length is not 4 bytes";
      return info;
    }
    info.kind = FrameInfo::Kind::position;
    info.count = static_cast<std::uint32_t>(frame.data[0]) | static_cast<std::uint32_t>(frame.data[1]) << 8 |
                 static_cast<std::uint32_t>(frame.data[2]) << 16 | static_cast<std::uint32_t>(frame.data[3]) << 24;
    return info;
  }
  return info;
}

DbbDecoder::DbbDecoder(std::vector<EncoderScale> encoders, bool sync_producer, std::int64_t sync_period_ns)
    : encoders_(std::move(encoders)), producer_(sync_producer), echo_hole_ns_(2 * sync_period_ns) {
  if (encoders_.size() > max_encoders) encoders_.resize(max_encoders);
  all_mask_ = (1u << encoders_.size()) - 1u;
  last_m_.fill(std::numeric_limits<double>::quiet_NaN());
}

int DbbDecoder::index_of(std::uint8_t node) const noexcept {
  for (std::size_t i = 0; i < encoders_.size(); ++i) {
    if (encoders_[i].node_id == node) return static_cast<int>(i);
  }
  return -1;
}

bool DbbDecoder::flush(DbbCycle& cycle) {
  if (held_open_) return emit_held(cycle);  // then the open cycle has nothing yet (its first PDO closes the held one)
  if (!open_ || emitted_ || cur_.present == 0) return false;
  close_cycle(cycle);
  return true;
}

void DbbDecoder::resync(bool reset_counts) {
  open_ = false;
  echo_ = false;  // a new connection: its bus shows whether it echoes
  last_echo_ns_ = 0;
  held_open_ = false;
  behind_ = true;  // answers to the SYNCs of the old connection may still come
  emitted_ = false;
  gap_ = true;
  if (reset_counts) {
    have_count_.fill(false);
    last_m_.fill(std::numeric_limits<double>::quiet_NaN());
  }
}

void DbbDecoder::open_cycle(std::int64_t t_ns, std::uint32_t flags) {
  open_ = true;
  emitted_ = false;
  cur_ = DbbCycle{};
  cur_.t_sync_ns = t_ns;
  cur_.count = encoders_.size();
  cur_.flags = flags | (gap_ ? sample_after_gap : 0u);
  gap_ = false;
}

void DbbDecoder::close_cycle(DbbCycle& out) {
  if (cur_.present != all_mask_) {
    cur_.flags |= sample_partial;
    for (std::size_t i = 0; i < encoders_.size(); ++i) {
      if (!(cur_.present & (1u << i))) {
        cur_.position_m[i] = last_m_[i];  // hold
        ++missed_pdos_;
      }
    }
  }
  out = cur_;
  emitted_ = true;
}

bool DbbDecoder::emit_held(DbbCycle& out) {
  held_open_ = false;
  if (held_.present == 0) {
    // No node answered that SYNC: no sample, and the open cycle (not emitted: its first PDO or SYNC
    // closes the held one) follows a hole.
    ++empty_cycles_;
    cur_.flags |= sample_after_gap;
    return false;
  }
  const bool emitted = emitted_;  // close_cycle marks the open cycle; this one is not it
  std::swap(cur_, held_);
  close_cycle(out);
  std::swap(cur_, held_);
  emitted_ = emitted;
  return true;
}

std::int64_t DbbDecoder::unwrap(std::size_t i, std::uint32_t count) noexcept {
  if (!have_count_[i]) {
    have_count_[i] = true;
    unwrapped_[i] = static_cast<std::int32_t>(count);
  } else {
    const auto delta = static_cast<std::int32_t>(count - prev_count_[i]);
    unwrapped_[i] += delta;
  }
  prev_count_[i] = count;
  return unwrapped_[i];
}

bool DbbDecoder::end_open_cycle(DbbCycle& cycle) {
  if (!open_ || emitted_) return false;
  if (cur_.present != 0) {
    close_cycle(cycle);
    return true;
  }
  // No node answered this SYNC: no sample, a hole in the samples (a longer silence is a timeout).
  ++empty_cycles_;
  gap_ = true;  // the next cycle follows it
  return false;
}

bool DbbDecoder::sync_echoed(std::int64_t t_ns, DbbCycle& cycle) {
  bool ready = false;
  if (!echo_) {
    // The first echo: the bus's order decides from here on, not the frames' times. What the times had
    // assigned goes out as it stands (a bus that echoes does so from our first SYNC: nothing is open yet).
    echo_ = true;
    behind_ = false;
    if (held_open_) {
      ready = emit_held(cycle);
    } else if (open_ && !emitted_ && cur_.present != 0) {
      close_cycle(cycle);
      ready = true;
    }
    if (open_ && !emitted_ && (cur_.flags & sample_after_gap)) gap_ = true;  // a reconnect's, say: kept
    open_ = false;
  }
  if (end_open_cycle(cycle)) ready = true;  // our SYNC before's (a complete one went out at its last PDO)
  // Its time is the bus's (SocketCAN stamps the echo when the frame was sent); a SYNC two periods or more
  // after the one before follows a hole (the bus, or whoever echoes, held it up).
  const bool hole = echo_hole_ns_ > 0 && last_echo_ns_ != 0 && t_ns - last_echo_ns_ >= echo_hole_ns_;
  last_echo_ns_ = t_ns;
  open_cycle(t_ns, hole ? sample_after_gap : 0u);
  return ready;
}

bool DbbDecoder::sync_sent(std::int64_t t_ns, std::int64_t written_ns, DbbCycle& cycle) {
  if (echo_) return false;  // its echo opens its cycle
  bool ready = false;
  // Nothing stamped before the last SYNC's write returned came since: the held cycle is final (the
  // open one, empty, is held in its turn below).
  if (held_open_) ready = emit_held(cycle);
  if (open_ && !emitted_ && cur_.present == all_mask_) {
    close_cycle(cycle);
    ready = true;
    behind_ = false;
  } else if (open_ && !emitted_) {
    // Incomplete, or nothing yet: held until a PDO stamped after held_until_ns_ shows that nothing more
    // of it can come.
    held_ = cur_;
    held_open_ = true;
    // An empty cycle: the nodes answer late together, and an answer stamped during this SYNC's write is
    // theirs. A partial one: the node missing did not answer (a reboot, a lost frame), and its answer
    // stamped during the write may already be to this SYNC (the node's thread, woken by our write, can
    // run before our clock read after it), so the SYNC's time before the write is the boundary.
    held_until_ns_ = cur_.present == 0 ? written_ns : t_ns;
    behind_ = true;
  } else if (open_) {
    behind_ = false;  // emitted complete before this SYNC: the nodes keep up
  }
  open_cycle(t_ns, 0);
  return ready;
}

void DbbDecoder::store(std::size_t i, std::uint32_t count, DbbCycle& into) {
  const double pos = count_to_position(encoders_[i], unwrap(i, count));
  into.position_m[i] = pos;
  last_m_[i] = pos;
  into.present |= 1u << i;
}

void DbbDecoder::feed_position_as_producer(std::size_t i, std::uint32_t count, std::int64_t t_ns, Result& r,
                                           DbbCycle& cycle) {
  const std::uint32_t bit = 1u << i;
  if (held_open_) {
    if (t_ns < held_until_ns_ && !(held_.present & bit)) {  // on the bus before our SYNC, read after it
      store(i, count, held_);
      if (held_.present == all_mask_) r.cycle_ready = emit_held(cycle);
      return;
    }
    r.cycle_ready = emit_held(cycle);  // stamped after our SYNC: nothing more of the held cycle can come
  }
  if (cur_.present & bit) ++late_pdos_;  // we sent every SYNC: the first was a late answer to the one before
  store(i, count, cur_);
  // While the nodes keep up a complete cycle is final at once; behind, a late answer may still be replaced.
  if (!behind_ && !emitted_ && cur_.present == all_mask_) {
    close_cycle(cycle);
    r.cycle_ready = true;
  }
}

DbbDecoder::Result DbbDecoder::feed(const can_frame& frame, std::int64_t t_ns, DbbCycle& cycle) {
  Result r;
  r.info = classify_frame(frame);
  switch (r.info.kind) {
    case FrameInfo::Kind::sync:
      if (producer_) {
        r.cycle_ready = sync_echoed(t_ns, cycle);
        break;
      }
      if (held_open_) {
        r.cycle_ready = emit_held(cycle);
        if (open_ && !emitted_ && cur_.present == 0) {  // the cycle after the held one got nothing
          ++empty_cycles_;
          gap_ = true;
        }
      } else {
        r.cycle_ready = end_open_cycle(cycle);
      }
      open_cycle(t_ns, 0);
      break;
    case FrameInfo::Kind::position: {
      const int idx = index_of(r.info.node);
      if (idx < 0 || !open_) break;  // not ours, or before the first SYNC
      const auto i = static_cast<std::size_t>(idx);
      if (producer_ && !echo_) {
        feed_position_as_producer(i, r.info.count, t_ns, r, cycle);
        break;
      }
      if (cur_.present & (1u << i)) {
        // A second PDO from this node in one cycle: the SYNC between them was missed.
        ++missed_syncs_;
        if (!emitted_) {
          close_cycle(cycle);
          r.cycle_ready = true;
        }
        gap_ = true;
        open_cycle(t_ns, 0);
      }
      store(i, r.info.count, cur_);
      if (cur_.present == all_mask_ && !r.cycle_ready) {  // at most one cycle per frame
        close_cycle(cycle);
        r.cycle_ready = true;
      }
      break;
    }
    default:
      break;
  }
  return r;
}

}  // namespace guideway::drivers::dbb
